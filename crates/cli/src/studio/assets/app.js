// Lifted studio: the page's logic. Plain JavaScript, no library: the server
// draws every plot as SVG; this script only gathers the options, calls the
// JSON API (documented in lifted_cli::studio) and puts the answers in place.
// Text from the record (column names, messages) goes in as text nodes,
// never as markup; only the server's own SVG figures are inserted as markup,
// under the page's content security policy.
"use strict";

const $ = (id) => document.getElementById(id);

// The session token the server put in the page; every API call sends it.
const TOKEN = document.querySelector('meta[name="lifted-token"]').content;

// This tab's session: a random id drawn on load and sent with every call,
// so that another tab has its own record and models.
const SESSION = Array.from(crypto.getRandomValues(new Uint8Array(16)))
  .map((b) => b.toString(16).padStart(2, "0"))
  .join("");

// A number with `digits` decimals, or `none` when it is null, NaN or
// infinite (an unstable model's fit is null in JSON).
function fixed(x, digits, none) {
  return typeof x === "number" && Number.isFinite(x) ? x.toFixed(digits) : none === undefined ? "n/a" : none;
}

const state = {
  info: null,        // DataInfo of the loaded record
  order: "auto",     // "auto" or the slider's order
  q: null,           // null: the command's default q
  busy: false,
  pending: null,     // the latest request made while busy
  seq: 0,           // sequence number of the latest identify request sent
  shown: 0,          // sequence number of the answer on the page (0: none)
  generation: 0,     // completed identifications
  digests: {},       // the digest of each figure shown, by slot
  views: 0,          // completed channel views
  failed: 0,         // failed calls
  csp: 0,            // content-security-policy violations seen
  window: null,      // the time plots' zoom [t0, t1] in seconds (null: whole record)
  extent: null,      // the whole record [0, (N - 1) T]
  structure: {},     // horizon and (A, C) route the last automatic order used
  refineOnce: false, // the next identification refines (PEM)
  boardSelected: [], // ids of the board's models drawn in its overlays
  boards: 0,         // board answers shown
  ranges: { estimation: null, validation: null }, // [t0, t1] seconds, null: all rows
  experiments: [],   // names of the further experiments
  expired: false,    // the server dropped this tab's session (410)
  confirmed: true,   // the user confirmed guessed inputs and outputs
  plan: null,        // { name, options }: the options come from a plan file
};

function showError(msg) {
  const e = $("error");
  e.textContent = msg;
  e.hidden = false;
}

function clearError() {
  $("error").hidden = true;
  $("error").textContent = "";
}

function setStatus(text) {
  $("status").textContent = text;
}

// A GET (no body) or a POST of `body` with its content type (JSON unless
// given), with the token header.
async function call(path, body, type) {
  const headers = { "X-Lifted-Token": TOKEN, "X-Lifted-Session": SESSION };
  const init = { headers };
  if (body !== undefined) {
    init.method = "POST";
    init.body = body;
    headers["Content-Type"] = type || "application/json";
  }
  let res;
  try {
    res = await fetch(path, init);
  } catch (e) {
    throw new Error("the studio server does not answer (" + e.message + ")");
  }
  const text = await res.text();
  let json = null;
  try {
    json = JSON.parse(text);
  } catch (_) {
    /* not JSON */
  }
  if (!res.ok) {
    const msg = json && json.error ? json.error : "HTTP " + res.status + ": " + text;
    // 410: this tab's session is gone (more tabs opened since, or the
    // server restarted). Say so where the record's name stands: the name
    // no longer has a record behind it on the server.
    if (res.status === 410) expired(msg);
    throw new Error(msg);
  }
  return json;
}

// The tab's session is gone: the page says so and stops sending work.
function expired(msg) {
  state.expired = true;
  $("data-name").textContent = "Session expired: " + msg;
  $("data-name").classList.add("expired");
  setStatus("session expired: reload the page");
  showError(msg);
}

function checked(boxId) {
  return Array.from(document.querySelectorAll("#" + boxId + " input:checked")).map((c) => c.value);
}

function listOf(text) {
  return text.split(",").map((s) => s.trim()).filter((s) => s.length > 0);
}

// The label text of a field, for messages.
function labelOf(id) {
  const l = $(id).closest("label");
  const span = l && l.querySelector("span");
  return span ? span.textContent : id;
}

// A number field's value: null when empty (the command's default applies),
// else a finite number (an integer ≥ `min` when asked); anything else is
// an error that names the field, never a silent default.
function num(id, integer, min) {
  const field = $(id);
  field.removeAttribute("aria-invalid");
  const v = field.value.trim();
  const bad = (why) => {
    field.setAttribute("aria-invalid", "true");
    return new Error(labelOf(id) + ": " + why);
  };
  if (field.validity && field.validity.badInput) throw bad("not a number");
  if (v === "") return null;
  const x = Number(v);
  if (!Number.isFinite(x)) throw bad("'" + v + "' is not a number");
  if (integer && !Number.isInteger(x)) throw bad("'" + v + "' is not a whole number");
  if (min !== undefined && x < min) throw bad(v + " is below " + min);
  return x;
}

// A comma-separated list of numbers (the output weighting).
function numbers(id) {
  const field = $(id);
  field.removeAttribute("aria-invalid");
  return listOf(field.value).map((w) => {
    const x = Number(w);
    if (!Number.isFinite(x)) {
      field.setAttribute("aria-invalid", "true");
      throw new Error(labelOf(id) + ": '" + w + "' is not a number");
    }
    return x;
  });
}

// The Request of the API: only the options the user set, so that the
// command's defaults apply to the rest. Throws on a field that is not a
// number.
function request(withOrder) {
  const r = { inputs: checked("inputs-box"), outputs: checked("outputs-box") };
  const ts = num("ts", false, 0);
  if (ts !== null) r.ts = ts;
  const hold = num("hold", true, 1);
  if (hold !== null) r.hold = hold;
  const periods = listOf($("output-period").value);
  if (periods.length) r.output_period = periods;
  if (state.window) r.window = state.window;
  if (state.ranges.estimation) r.estimation_range = state.ranges.estimation;
  if (state.ranges.validation) r.validation_range = state.ranges.validation;
  if (!withOrder) return r;
  // The bands' level (a view option, not an identify option).
  if ($("confidence").value !== "0.95") r.confidence = Number($("confidence").value);
  if (state.plan) {
    // The options are the plan's (`lifted identify --plan`); the option
    // fields are not sent.
    r.plan = state.plan.options;
    r.have = state.digests;
    return r;
  }
  const method = $("method").value;
  r.method = method;
  r.order = String(state.order);
  r.detrend = $("detrend").value;
  if (state.refineOnce) r.refine = "pem";
  // The figures shown: the server leaves out those that did not change.
  r.have = state.digests;
  if (POLYNOMIAL.includes(method) || method === "process") {
    // The model families: MATLAB's order vector (else the slider's order
    // n: na = nb = n for ARX), or the process structure.
    const orders = $("orders").value.trim();
    if (POLYNOMIAL.includes(method) && orders) {
      r.orders = orders;
      delete r.order;
    }
    // The regularised FIR takes its lags from the orders (default "70 1"),
    // not from the slider.
    if (method === "impulse") delete r.order;
    if (KERNEL.includes(method) && $("kernel").value) r.kernel = $("kernel").value;
    if (A_STRUCTURE.includes(method) && $("a-structure").value) r.a_structure = $("a-structure").value;
    if (F_STRUCTURE.includes(method) && $("f-structure").value) r.f_structure = $("f-structure").value;
    if (method === "process") {
      r.process = $("process").value;
      if ($("intersample").value !== "zoh") r.intersample = $("intersample").value;
      delete r.order;
    }
    return r;
  }
  if ($("stable").checked) r.stable = true;
  if ($("method").value !== "qmarkov" && $("feedthrough").value !== "") r.feedthrough = $("feedthrough").value === "true";
  if (method === "qmarkov") {
    const n = num("prbs-order", true, 2);
    if (n !== null) r.prbs_order = n;
    const a = num("amplitude", false);
    if (a !== null) r.amplitude = a;
    const w = numbers("output-weight");
    if (w.length) r.output_weight = w;
    if (state.q !== null) r.q = state.q;
  } else {
    const h = num("horizon", true, 1);
    if (h !== null) r.horizon = h;
    const crit = $("order-criterion").value;
    if (crit !== "validation" && method !== "pbsid" && method !== "ssarx" && method !== "pbsid-rowwise") r.order_criterion = crit;
    // A numeric order keeps the structure the automatic order chose (the
    // server makes it explicit on the command line).
    // A horizon i holds orders up to (i − 1) n_y: a larger order takes
    // the server's default horizon instead.
    if (state.order !== "auto" && method !== "iv") {
      const hz = state.structure.horizon;
      const ny = Math.max(1, r.outputs.length);
      if (h === null && hz && state.order <= (hz - 1) * ny) r.horizon = hz;
      if (state.structure.estimator) r.estimator = state.structure.estimator;
    }
  }
  if (method === "iv") {
    const f = listOf($("instrument").value);
    if (f.length) r.instrument = f;
  }
  return r;
}

// The polynomial model families (`lifted identify --method arx …`).
const POLYNOMIAL = ["arx", "armax", "oe", "bj", "fir", "impulse"];
// The methods with a regularisation kernel (`--kernel`).
const KERNEL = ["arx", "impulse"];
// The methods whose A matrix has a pattern (`--a-structure`).
const A_STRUCTURE = ["arx", "armax"];
// The methods whose F polynomials may be shared by the inputs (`--f-structure`).
const F_STRUCTURE = ["oe", "bj"];

function methodFields() {
  const m = $("method").value;
  const family = POLYNOMIAL.includes(m) || m === "process";
  document.querySelectorAll(".qm-only").forEach((e) => e.classList.toggle("hidden", m !== "qmarkov"));
  document.querySelectorAll(".sub-only").forEach((e) => e.classList.toggle("hidden", m === "qmarkov" || family));
  document.querySelectorAll(".poly-only").forEach((e) => e.classList.toggle("hidden", !POLYNOMIAL.includes(m)));
  document.querySelectorAll(".proc-only").forEach((e) => e.classList.toggle("hidden", m !== "process"));
  document.querySelectorAll(".arx-only").forEach((e) => e.classList.toggle("hidden", !A_STRUCTURE.includes(m)));
  document.querySelectorAll(".oe-only").forEach((e) => e.classList.toggle("hidden", !F_STRUCTURE.includes(m)));
  document.querySelectorAll(".kernel-only").forEach((e) => e.classList.toggle("hidden", !KERNEL.includes(m)));
  document.querySelectorAll(".iv-only").forEach((e) => e.classList.toggle("hidden", m !== "iv"));
  qRange();
}

// q < n_r m (eq. III-8): the slider's range follows the PRBS order and hold.
function qRange() {
  const n = Number($("prbs-order").value || 8);
  const hold = Number($("hold").value || 1);
  const max = Math.max(2, hold * (Math.pow(2, n) - 1) - 1);
  const s = $("q-slider");
  s.max = String(max);
  if (Number(s.value) > max) s.value = String(max);
}

// An element with text content (never markup).
function el(tag, text, cls) {
  const e = document.createElement(tag);
  if (text !== undefined) e.textContent = String(text);
  if (cls) e.className = cls;
  return e;
}

// A table's rows from arrays of cells (header row first), as text.
function fillTable(table, head, rows) {
  const tr = el("tr");
  for (const h of head) tr.appendChild(el("th", h));
  const all = [tr];
  for (const cells of rows) {
    const r = el("tr");
    for (const c of cells) r.appendChild(c instanceof Node ? c : el("td", c));
    all.push(r);
  }
  table.replaceChildren(...all);
}

// The Save links: real links only while a model of the current options
// is shown, to that very model (its request's sequence number `seq`); else
// no href, aria-disabled, and clicks ignored.
function setSaves(enabled, seq) {
  $("refine").disabled = !enabled;
  $("keep").disabled = !enabled;
  for (const id of ["save-model", "save-report", "save-data", "save-plan"]) {
    const a = $(id);
    if (enabled) {
      a.href = a.dataset.path + "?token=" + encodeURIComponent(TOKEN) + "&session=" + SESSION + "&seq=" + seq;
      a.setAttribute("aria-disabled", "false");
      a.classList.remove("disabled");
    } else {
      a.removeAttribute("href");
      a.setAttribute("aria-disabled", "true");
      a.classList.add("disabled");
    }
  }
}

// Clears what an identification showed (its figures, fits, command) and
// disables the Save links: after a failed identification nothing of the
// previous model remains to be mistaken for the current one.
function clearIdentified() {
  state.digests = {};
  $("refinement").textContent = "";
  $("gain").textContent = "";
  $("feedback").textContent = "";
  $("warnings").replaceChildren();
  for (const id of ["fig-criterion", "fig-order", "fits", "poles", "fig-response", "fig-error", "fig-residuals", "fig-step", "fig-bode", "fig-pz", "matrices", "tfs", "parameters"]) {
    $(id).replaceChildren();
  }
  $("parameters").hidden = true;
  $("parameters-note").hidden = true;
  $("stability").hidden = true;
  $("stability").textContent = "";
  $("command").textContent = "";
  $("order-kind").textContent = "";
  setSaves(false);
}

function channelBoxes(info) {
  const fill = (boxId, legend, selected) => {
    const box = $(boxId);
    box.replaceChildren(el("legend", legend));
    for (const c of info.columns) {
      const label = document.createElement("label");
      const cb = document.createElement("input");
      cb.type = "checkbox";
      cb.value = c.name;
      cb.checked = selected.includes(c.name);
      cb.addEventListener("change", () => schedule({ view: true, identify: true }));
      label.appendChild(cb);
      const rate = c.samples < info.rows ? " (" + c.samples + " samples" + (c.period ? ", every " + c.period : "") + ")" : "";
      label.appendChild(document.createTextNode(" " + c.name + rate));
      box.appendChild(label);
    }
  };
  fill("inputs-box", "Inputs", info.suggested_inputs);
  fill("outputs-box", "Outputs", info.suggested_outputs);
}

// The range fields show the ranges (empty: all rows).
function fillRanges() {
  const put = (id, v) => { $(id).value = v === null ? "" : String(+v.toPrecision(6)); };
  const e = state.ranges.estimation;
  const v = state.ranges.validation;
  put("est-t0", e ? e[0] : null);
  put("est-t1", e ? e[1] : null);
  put("vr-t0", v ? v[0] : null);
  put("vr-t1", v ? v[1] : null);
}

function setRanges(est, val) {
  state.ranges = { estimation: est, validation: val };
  fillRanges();
  schedule({ view: true, identify: true });
}

// A range from two fields: null when both are empty; an open end is the
// record's.
function rangeOf(a, b, what) {
  const t0 = num(a, false);
  const t1 = num(b, false);
  if (t0 === null && t1 === null) return null;
  const ext = state.extent || [0, 0];
  const r = [t0 === null ? ext[0] : t0, t1 === null ? ext[1] : t1];
  if (!(r[0] < r[1])) throw new Error(what + ": the start must be before the end");
  return r;
}

function setup(info) {
  state.info = info;
  // A new record drops the further experiments (the server does too).
  state.experiments = [];
  $("exp-names").textContent = "The record alone.";
  $("exp-clear").disabled = true;
  state.ranges = { estimation: null, validation: null };
  fillRanges();
  $("delay").disabled = false;
  $("delays").replaceChildren();
  state.order = "auto";
  state.window = null;
  state.structure = {};
  fillWindow();
  $("ts").placeholder = info.has_time ? "from t column" : "1 (no time column)";
  $("data-name").textContent = info.name + ": " + info.rows + " rows, " +
    (info.has_time ? "T = " + info.ts + " s" : "no time column (base period: the T field, 1 s if empty)") +
    ", columns " + info.columns.map((c) => c.name).join(", ");
  channelBoxes(info);
  clearIdentified();
  // Guessed channels: shown, but nothing identified until confirmed.
  state.confirmed = !info.channels_guessed;
  $("confirm-channels").hidden = state.confirmed;
  schedule({ view: true, identify: state.confirmed });
}

async function loadFile(file) {
  clearError();
  setStatus("loading " + file.name + "…");
  try {
    const buf = await file.arrayBuffer();
    const info = await call("/api/data?name=" + encodeURIComponent(file.name), buf, "application/octet-stream");
    setup(info);
  } catch (e) {
    // The server keeps the record it had (a file replaces it only once
    // read whole), and so does the page.
    setStatus(state.info ? state.info.name + " kept" : "no data");
    showError(e.message);
  }
}

function renderView(v) {
  state.extent = [0, Math.max(v.rows - 1, 1) * v.ts];
  $("fig-inputs").innerHTML = v.inputs_svg;
  $("fig-outputs").innerHTML = v.outputs_svg;
  const rows = [];
  for (const c of v.inputs) rows.push([c.name, "input", "hold " + c.period + " T", c.samples]);
  for (const c of v.outputs) rows.push([c.name, "output", c.period + " T", c.samples]);
  fillTable($("rates"), ["channel", "kind", "period", "samples"], rows);
  state.views += 1;
  $("status").dataset.view = String(state.views);
}

// The poles as a list, those outside the unit circle marked.
function renderPoles(poles) {
  const items = poles.map(([re, im]) => {
    const m = Math.hypot(re, im);
    const sign = im < 0 ? " − " : " + ";
    const text = fixed(re, 4) + (im === 0 ? "" : sign + fixed(Math.abs(im), 4) + "i") + "  |p| = " + fixed(m, 4);
    const outside = !(m < 1);
    const li = el("li", outside ? text + "  (outside the unit circle)" : text, outside ? "outside" : undefined);
    return li;
  });
  $("poles").replaceChildren(...items);
}

// A matrix as a table of numbers (4 significant digits), captioned.
function matrixTable(name, rows) {
  const t = el("table");
  t.appendChild(el("caption", name + " (" + rows.length + " × " + (rows[0] ? rows[0].length : 0) + ")"));
  for (const r of rows) {
    const tr = el("tr");
    for (const x of r) tr.appendChild(el("td", typeof x === "number" ? x.toPrecision(4) : String(x)));
    t.appendChild(tr);
  }
  return t;
}

function renderModel(r) {
  const m = r.matrices;
  const tables = [matrixTable("A", m.a), matrixTable("B", m.b), matrixTable("C", m.c), matrixTable("D", m.d)];
  if (m.k) tables.push(matrixTable("K", m.k));
  $("matrices").replaceChildren(...tables);
  const rows = r.transfer_functions.map((g) => [g.output + " ← " + g.input, g.num, g.den]);
  if (r.transfer_note) rows.push([r.transfer_note, "", ""]);
  fillTable($("tfs"), ["channel", "numerator", "denominator"], rows);
  // The parameters ± σ (text, as `lifted analyze` prints them).
  $("parameters").textContent = r.parameters || "";
  $("parameters").hidden = !r.parameters;
  $("parameters-note").hidden = !r.parameters;
}

// Puts an identification's answer on the page. The slider is never moved
// by an answer (the user may have moved it since), except to show the
// order `auto` chose while the slider is on auto.
function renderIdentified(r) {
  const sel = r.order_selection;
  const slider = $("order-slider");
  const keep = Number(slider.value);
  let max = sel && sel.values.length > 0 ? Math.max(1, Math.min(sel.values.length, 60)) : Math.max(10, r.order);
  if (state.order !== "auto") max = Math.max(max, keep);
  slider.max = String(max);
  $("order-kind").textContent = sel && sel.values.length > 0
    ? sel.kind + (sel.suggested_order ? "; largest gap at order " + sel.suggested_order : "")
    : "";
  slider.disabled = false;
  if (state.order === "auto") {
    slider.value = String(r.order);
    $("order-value").textContent = r.order + " (auto)";
  } else {
    slider.value = String(keep);
    $("order-value").textContent = String(state.order);
  }
  // A slot the server did not send again still shows the same figure.
  const changed = (slot) => !(r.unchanged || []).includes(slot);
  if (!changed("order")) {
    // Kept.
  } else if (r.figures.order) {
    $("fig-order").innerHTML = r.figures.order;
  } else {
    $("fig-order").replaceChildren(el("p", "This route gives no order-selection values.", "note"));
  }
  // The one-step column only for a model with a Kalman gain.
  const oneStep = r.fits.some((f) => f.one_step !== null && f.one_step !== undefined);
  const fits = r.fits.map((f) => {
    const text = f.stable === false ? "n/a: unstable" : fixed(f.fit, 2);
    const fit = el("td", text, "fit");
    fit.dataset.output = f.output;
    const row = [f.output, fit];
    if (oneStep) row.push(f.stable === false ? "n/a: unstable" : fixed(f.one_step, 2));
    return row.concat([f.white ? "yes" : "no", f.independent ? "yes" : "no"]);
  });
  const head = ["output", "fit % (simulation)"];
  if (oneStep) head.push("fit % (1-step)");
  fillTable($("fits"), head.concat(["white residual", "independent of u"]), fits);
  const gain = r.gain;
  const known = (x) => x !== null && x !== undefined;
  $("gain").textContent = gain
    ? "Kalman gain: " + gain.used + "." + (known(gain.final_cost)
      ? " One-step prediction error on the records " + fixed(gain.final_cost, 5) +
        (known(gain.riccati_cost) ? "; with the subspace step's gain " + fixed(gain.riccati_cost, 5) : "") +
        (known(gain.zero_cost) ? "; with none (the simulation) " + fixed(gain.zero_cost, 5) : "") + "."
      : "")
    : "";
  $("feedback").textContent = r.feedback ? "Feedback: " + r.feedback + "." : "";
  $("warnings").replaceChildren(...(r.warnings || []).map((w) => el("li", w)));
  const stab = $("stability");
  if (r.stable === false) {
    stab.textContent = "Unstable model: spectral radius ρ(A) = " + fixed(r.spectral_radius, 4, "∞") +
      " ≥ 1; its simulation diverges, so the fit is not meaningful (poles outside the unit circle are marked).";
    stab.hidden = false;
  } else {
    stab.hidden = true;
    stab.textContent = "";
  }
  renderPoles(r.poles || []);
  if (changed("response")) $("fig-response").innerHTML = r.figures.response.join("");
  if (changed("error")) $("fig-error").innerHTML = r.figures.error.join("");
  if (changed("residuals")) $("fig-residuals").innerHTML = r.figures.residuals.join("");
  if (changed("criterion")) $("fig-criterion").innerHTML = r.figures.criterion || "";
  renderModel(r);
  const judgeText = (j) => {
    if (!j) return "";
    const h = j.held_out;
    const fits = h ? " (held-out fit over " + h.folds + " blocks: subspace model " + fixed(h.initial_fit, 1) + " %, refined " + fixed(h.refined_fit, 1) + " %)" : "";
    if (j.decided_by === "held-out blocks") return ", decided on held-out blocks" + fits;
    if (j.decided_by === "held-out blocks: not told apart") return ", the held-out blocks do not tell the two apart" + fits;
    return ", decided on the record" + fits;
  };
  const ref = r.refinement;
  $("refinement").textContent = ref
    ? "PEM refinement: " + ref.iterations + " iterations, cost " + fixed(ref.initial_cost, 6) + " → " +
      fixed(ref.final_cost, 6) + " (" + ref.termination + "; " + (ref.kept === "Refined" ? "refined model kept" : "initial model kept") + judgeText(ref.judge) + ")"
    : "";
  if (state.order === "auto") state.structure = { horizon: r.horizon, estimator: r.estimator };
  if (changed("step")) $("fig-step").innerHTML = r.figures.step;
  if (changed("bode")) $("fig-bode").innerHTML = r.figures.bode;
  if (changed("pz")) $("fig-pz").innerHTML = r.figures.pz;
  state.digests = r.figure_digests || {};
  $("command").textContent = r.command;
  $("validation-data").textContent = r.validation_data;
  state.shown = r.seq;
  setSaves(true, r.seq);
  state.generation += 1;
  $("status").dataset.generation = String(state.generation);
  $("status").dataset.seq = String(r.seq);
  $("status").dataset.order = String(r.order);
  setStatus(r.method + ", order " + r.order + (r.stable === false ? " (unstable)" : "") + " — " + fixed(r.elapsed_ms, 0, "?") + " ms");
}

// The time from the request until the answer (data-answered-ms) and until
// the browser has painted its figures (data-drawn-ms: the frame after the
// update, then the task after it), in the status line.
function drawnAfter(r, sent, answered) {
  requestAnimationFrame(() => setTimeout(() => {
    if (state.shown !== r.seq) return;
    const status = $("status");
    const drawn = performance.now() - sent;
    status.dataset.answeredMs = (answered - sent).toFixed(1);
    status.dataset.drawnMs = drawn.toFixed(1);
    status.dataset.serverMs = Number(r.elapsed_ms).toFixed(1);
    status.dataset.drawnSeq = String(r.seq);
    setStatus(r.method + ", order " + r.order + (r.stable === false ? " (unstable)" : "") + " — " +
      fixed(r.elapsed_ms, 0, "?") + " ms on the server, drawn in " + drawn.toFixed(0) + " ms");
  }, 0));
}

// One request at a time; while one runs, only the latest of the requests
// made meanwhile is kept (a slider drag sends far fewer calls than events).
function schedule(job) {
  if (!state.info || state.expired) return;
  if (!state.confirmed) job = { view: job.view };
  if (state.busy) {
    state.pending = {
      view: job.view || (state.pending && state.pending.view),
      identify: job.identify || (state.pending && state.pending.identify),
    };
    return;
  }
  run(job);
}

async function run(job) {
  state.busy = true;
  $("status").dataset.busy = "1";
  clearError();
  try {
    if (job.view) renderView(await call("/api/view", JSON.stringify(request(false))));
    if (job.identify) {
      setStatus("identifying…");
      const req = request(true);
      state.refineOnce = false;
      state.seq += 1;
      req.seq = state.seq;
      const sent = performance.now();
      const r = await call("/api/identify", JSON.stringify(req));
      const answered = performance.now();
      // An answer older than the latest request is dropped: the page shows
      // (and saves) only the model of the options it was last asked for.
      if (r.seq === state.seq) {
        renderIdentified(r);
        drawnAfter(r, sent, answered);
      }
    }
  } catch (e) {
    // The figures and Save links of an earlier model do not belong to
    // these options (the server has dropped that model too).
    clearIdentified();
    state.failed += 1;
    $("status").dataset.failed = String(state.failed);
    showError(e.message);
    setStatus(state.expired ? "session expired: reload the page" : "error");
  }
  state.busy = false;
  $("status").dataset.busy = "0";
  const next = state.pending;
  state.pending = null;
  if (next) run(next);
}

// The zoom fields show the window (empty: whole record).
function fillWindow() {
  $("win-t0").value = state.window ? String(+state.window[0].toPrecision(6)) : "";
  $("win-t1").value = state.window ? String(+state.window[1].toPrecision(6)) : "";
}

// Sets the time plots' window (null: the whole record), clamped to the
// record, and redraws the time plots (and the model's, if shown).
function setWindow(w) {
  const ext = state.extent;
  if (w && ext) {
    let [a, b] = w;
    const span = Math.max(b - a, 1e-12);
    if (a < ext[0]) [a, b] = [ext[0], ext[0] + span];
    if (b > ext[1]) [a, b] = [Math.max(ext[0], ext[1] - span), ext[1]];
    w = a <= ext[0] && b >= ext[1] ? null : [a, b];
  }
  state.window = w;
  fillWindow();
  schedule({ view: true, identify: state.shown > 0 });
}

// Where the pointer is on a time plot, as a time: the plot area of the
// server's figures spans x = 70 … W − 10 of a W pixels wide SVG, over the
// window padded by 5 % on each side (crate::plot).
function timeAt(svg, clientX) {
  const rect = svg.getBoundingClientRect();
  const w = Number(svg.getAttribute("width")) || rect.width;
  const px = (clientX - rect.left) * (w / rect.width);
  const f = Math.min(1, Math.max(0, (px - 70) / (w - 80)));
  const [a, b] = state.window || state.extent;
  const d = b - a;
  return a - 0.05 * d + f * 1.1 * d;
}

function wireZoom(div) {
  div.addEventListener("wheel", (e) => {
    const svg = div.querySelector("svg");
    if (!svg || !state.extent) return;
    e.preventDefault();
    const t = timeAt(svg, e.clientX);
    const [a, b] = state.window || state.extent;
    const k = e.deltaY < 0 ? 0.5 : 2;
    setWindow([t - (t - a) * k, t + (b - t) * k]);
  }, { passive: false });
  let drag = null;
  div.addEventListener("mousedown", (e) => {
    const svg = div.querySelector("svg");
    if (!svg || !state.extent || e.button !== 0) return;
    e.preventDefault();
    drag = { x: e.clientX, t: timeAt(svg, e.clientX), svg };
    div.classList.add("dragging");
  });
  window.addEventListener("mouseup", (e) => {
    if (!drag) return;
    const d = drag;
    drag = null;
    div.classList.remove("dragging");
    if (Math.abs(e.clientX - d.x) < 3) return;
    const mode = (document.querySelector('input[name="drag"]:checked') || {}).value;
    if (mode === "estimation" || mode === "validation") {
      const t1 = timeAt(d.svg, e.clientX);
      const ext = state.extent;
      const r = [Math.max(ext[0], Math.min(d.t, t1)), Math.min(ext[1], Math.max(d.t, t1))];
      const next = Object.assign({}, state.ranges);
      next[mode] = r;
      setRanges(next.estimation, next.validation);
      return;
    }
    const shift = d.t - timeAt(d.svg, e.clientX);
    const [a, b] = state.window || state.extent;
    setWindow([a + shift, b + shift]);
  });
  div.addEventListener("dblclick", () => setWindow(null));
}

// The board's answer: the fit table (a checkbox per model to overlay it,
// its Save link and a Remove button) and the overlays of the ticked ones.
function renderBoard(b) {
  $("board-data").textContent = b.data;
  state.boardSelected = b.entries.filter((e) => e.selected).map((e) => e.id);
  const outputs = [];
  for (const e of b.entries) for (const [o] of e.fits) if (!outputs.includes(o)) outputs.push(o);
  const rows = b.entries.map((e) => {
    const tick = el("td");
    const cb = document.createElement("input");
    cb.type = "checkbox";
    cb.checked = e.selected;
    cb.dataset.id = String(e.id);
    cb.addEventListener("change", () => {
      const sel = state.boardSelected.filter((x) => x !== e.id);
      if (cb.checked) sel.push(e.id);
      boardCall({ selected: sel });
    });
    tick.appendChild(cb);
    const fits = outputs.map((o) => {
      const f = e.fits.find((x) => x[0] === o);
      const c = el("td", !f ? "–" : e.stable ? fixed(f[1], 2) : "n/a: unstable", "num");
      return c;
    });
    const save = el("td");
    const a = el("a", "save", "button");
    a.href = "/api/model?token=" + encodeURIComponent(TOKEN) + "&session=" + SESSION + "&board=" + e.id;
    a.setAttribute("download", "model-" + e.id + ".json");
    save.appendChild(a);
    const rm = el("td");
    const b2 = el("button", "remove");
    b2.type = "button";
    b2.addEventListener("click", () => boardCall({ remove: e.id, selected: state.boardSelected.filter((x) => x !== e.id) }));
    rm.appendChild(b2);
    const cmd = el("td");
    cmd.appendChild(el("code", e.command));
    return [tick, e.label, ...fits, save, rm, cmd];
  });
  fillTable($("board"), ["show", "model", ...outputs.map((o) => "fit % " + o), "", "", "command"], rows);
  $("board-response").innerHTML = b.response.join("");
  $("board-step").innerHTML = b.step || "";
  $("board-bode").innerHTML = b.bode || "";
  state.boards += 1;
  $("status").dataset.board = String(state.boards);
}

async function boardCall(body) {
  clearError();
  try {
    if (state.window) body.window = state.window;
    renderBoard(await call("/api/board", JSON.stringify(body)));
  } catch (e) {
    showError(e.message);
  }
}

// Further experiments: appended in the order chosen (q-Markov: one file
// per input, in input order), each a --data of the command after the record.
async function addExperiments(files) {
  clearError();
  try {
    for (const file of files) {
      const buf = await file.arrayBuffer();
      await call("/api/data?role=experiment&name=" + encodeURIComponent(file.name), buf, "application/octet-stream");
      state.experiments.push(file.name);
    }
  } catch (e) {
    showError(e.message);
  }
  $("exp-names").textContent = state.experiments.length
    ? "The record, then " + state.experiments.join(", ") + "."
    : "The record alone.";
  $("exp-clear").disabled = state.experiments.length === 0;
  schedule({ identify: true });
}

async function loadValidation(file) {
  clearError();
  try {
    const buf = await file.arrayBuffer();
    const info = await call("/api/data?role=validation&name=" + encodeURIComponent(file.name), buf, "application/octet-stream");
    $("val-name").textContent = "Models are validated on " + info.name + " (" + info.rows + " rows).";
    $("val-clear").disabled = false;
    schedule({ identify: true });
    boardCall({ selected: state.boardSelected });
  } catch (e) {
    showError(e.message);
  }
}

function wire() {
  document.querySelectorAll(".timeplot").forEach(wireZoom);
  $("val-file").addEventListener("change", (e) => {
    if (e.target.files.length) loadValidation(e.target.files[0]);
  });
  $("exp-file").addEventListener("change", (e) => {
    if (e.target.files.length) addExperiments(Array.from(e.target.files));
  });
  $("plan-file").addEventListener("change", async (e) => {
    const f = e.target.files[0];
    if (!f) return;
    try {
      const options = JSON.parse(await f.text());
      if (options === null || typeof options !== "object" || Array.isArray(options)) {
        throw new Error("not a JSON object");
      }
      state.plan = { name: f.name, options };
      $("plan-name").textContent = "Options from the plan " + f.name + " (the Method and Order fields are not used).";
      $("plan-clear").disabled = false;
      schedule({ identify: true });
    } catch (err) {
      showError("plan " + f.name + ": " + err.message);
    }
    e.target.value = "";
  });
  $("plan-clear").addEventListener("click", () => {
    state.plan = null;
    $("plan-name").textContent = "The options of the Method and Order blocks.";
    $("plan-clear").disabled = true;
    schedule({ identify: true });
  });
  $("exp-clear").addEventListener("click", async () => {
    try {
      await call("/api/experiments/clear", "{}");
      state.experiments = [];
      $("exp-names").textContent = "The record alone.";
      $("exp-clear").disabled = true;
      schedule({ identify: true });
    } catch (e) {
      showError(e.message);
    }
  });
  $("val-clear").addEventListener("click", async () => {
    try {
      await call("/api/validation/clear", "{}");
      $("val-name").textContent = "Models are validated on the estimation record.";
      $("val-clear").disabled = true;
      schedule({ identify: true });
      boardCall({ selected: state.boardSelected });
    } catch (e) {
      showError(e.message);
    }
  });
  $("refine").addEventListener("click", () => {
    state.refineOnce = true;
    schedule({ identify: true });
  });
  $("keep").addEventListener("click", () => {
    const sel = state.boardSelected.slice();
    boardCall({ add: state.shown, selected: sel });
  });
  $("delay").addEventListener("click", async () => {
    clearError();
    try {
      const d = await call("/api/delay", JSON.stringify(request(false)));
      const rows = d.pairs.map((p) => [
        p.input + " → " + p.output,
        p.interval ? "[" + p.interval[0] + ", " + p.interval[1] + ")" : "–",
        p.interval_s ? "[" + p.interval_s[0] + ", " + p.interval_s[1] + ") s" : p.failure || "",
      ]);
      fillTable($("delays"), ["pair", "delay d (T)", "delay (s) / why none"], rows);
      $("status").dataset.delays = String(Number($("status").dataset.delays || "0") + 1);
    } catch (e) {
      showError(e.message);
    }
  });
  $("win-apply").addEventListener("click", () => {
    clearError();
    try {
      const a = num("win-t0", false);
      const b = num("win-t1", false);
      if (a === null && b === null) return setWindow(null);
      const ext = state.extent || [0, 0];
      const w = [a === null ? ext[0] : a, b === null ? ext[1] : b];
      if (!(w[0] < w[1])) throw new Error("Time window: the start must be before the end");
      setWindow(w);
    } catch (e) {
      showError(e.message);
    }
  });
  $("win-reset").addEventListener("click", () => setWindow(null));
  $("ranges-apply").addEventListener("click", () => {
    clearError();
    try {
      setRanges(rangeOf("est-t0", "est-t1", "Estimation rows"), rangeOf("vr-t0", "vr-t1", "Validation rows"));
    } catch (e) {
      showError(e.message);
    }
  });
  $("ranges-clear").addEventListener("click", () => setRanges(null, null));
  // A Save link without a model does nothing, whatever the CSS.
  for (const id of ["save-model", "save-report", "save-data", "save-plan"]) {
    $(id).addEventListener("click", (e) => {
      if (e.currentTarget.getAttribute("aria-disabled") === "true") e.preventDefault();
    });
  }
  // A script error is a bug of the page: count it (the tests read it) and say so.
  window.addEventListener("error", (e) => {
    const n = Number($("status").dataset.jserrors || "0") + 1;
    $("status").dataset.jserrors = String(n);
    showError("page script error: " + e.message);
  });
  // Anything the content security policy blocks is a bug of the page: say so.
  document.addEventListener("securitypolicyviolation", (e) => {
    state.csp += 1;
    $("status").dataset.csp = String(state.csp);
    showError("blocked by the page's security policy: " + e.violatedDirective + " (" + (e.blockedURI || "inline") + ")");
  });
  $("confirm-button").addEventListener("click", () => {
    state.confirmed = true;
    $("confirm-channels").hidden = true;
    schedule({ view: true, identify: true });
  });
  $("file").addEventListener("change", (e) => {
    if (e.target.files.length) loadFile(e.target.files[0]);
  });
  const drop = $("drop");
  drop.addEventListener("dragover", (e) => {
    e.preventDefault();
    drop.classList.add("over");
  });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => {
    e.preventDefault();
    drop.classList.remove("over");
    if (e.dataTransfer.files.length) loadFile(e.dataTransfer.files[0]);
  });
  $("options").addEventListener("submit", (e) => {
    e.preventDefault();
    schedule({ view: true, identify: true });
  });
  $("method").addEventListener("change", () => {
    methodFields();
    state.order = "auto";
    schedule({ identify: true });
  });
  for (const id of ["ts", "hold", "output-period"]) {
    $(id).addEventListener("change", () => {
      qRange();
      schedule({ view: true, identify: true });
    });
  }
  for (const id of ["horizon", "prbs-order", "amplitude", "output-weight", "instrument", "detrend", "stable", "feedthrough", "order-criterion", "confidence", "orders", "process", "kernel", "intersample", "a-structure", "f-structure"]) {
    $(id).addEventListener("change", () => {
      qRange();
      schedule({ identify: true });
    });
  }
  $("order-slider").addEventListener("input", () => {
    state.order = Number($("order-slider").value);
    $("order-value").textContent = String(state.order);
    schedule({ identify: true });
  });
  $("order-auto").addEventListener("click", () => {
    state.order = "auto";
    schedule({ identify: true });
  });
  $("q-slider").addEventListener("input", () => {
    state.q = Number($("q-slider").value);
    $("q-value").textContent = String(state.q);
    schedule({ identify: true });
  });
  methodFields();
}

window.addEventListener("DOMContentLoaded", async () => {
  wire();
  try {
    // Open this tab's session (a copy of the server's default record).
    const info = await call("/api/session", "{}");
    $("status").dataset.session = "open";
    if (info) setup(info);
  } catch (e) {
    showError(e.message);
  }
});
