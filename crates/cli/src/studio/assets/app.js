// Lifted studio: the page's logic. Plain JavaScript, no library: the server
// draws every plot as SVG; this script only gathers the options, calls the
// JSON API (documented in lifted_cli::studio) and puts the answers in place.
"use strict";

const $ = (id) => document.getElementById(id);

const state = {
  info: null,        // DataInfo of the loaded record
  order: "auto",     // "auto" or the slider's order
  q: null,           // null: the command's default q
  busy: false,
  pending: null,     // the latest request made while busy
  generation: 0,     // completed identifications
  views: 0,          // completed channel views
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

async function call(path, body) {
  const init = body === undefined ? {} : { method: "POST", body };
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
    throw new Error(json && json.error ? json.error : "HTTP " + res.status + ": " + text);
  }
  return json;
}

function checked(boxId) {
  return Array.from(document.querySelectorAll("#" + boxId + " input:checked")).map((c) => c.value);
}

function listOf(text) {
  return text.split(",").map((s) => s.trim()).filter((s) => s.length > 0);
}

// The Request of the API: only the options the user set, so that the
// command's defaults apply to the rest.
function request(withOrder) {
  const r = { inputs: checked("inputs-box"), outputs: checked("outputs-box") };
  const num = (id) => {
    const v = $(id).value.trim();
    return v === "" ? null : Number(v);
  };
  const ts = num("ts");
  if (ts !== null) r.ts = ts;
  const hold = num("hold");
  if (hold !== null) r.hold = hold;
  const periods = listOf($("output-period").value);
  if (periods.length) r.output_period = periods;
  if (!withOrder) return r;
  const method = $("method").value;
  r.method = method;
  r.order = String(state.order);
  r.detrend = $("detrend").value;
  if ($("stable").checked) r.stable = true;
  if (method === "qmarkov") {
    const n = num("prbs-order");
    if (n !== null) r.prbs_order = n;
    const a = num("amplitude");
    if (a !== null) r.amplitude = a;
    const w = listOf($("output-weight").value).map(Number);
    if (w.length) r.output_weight = w;
    if (state.q !== null) r.q = state.q;
  } else {
    const h = num("horizon");
    if (h !== null) r.horizon = h;
  }
  if (method === "iv") {
    const f = listOf($("instrument").value);
    if (f.length) r.instrument = f;
  }
  return r;
}

function methodFields() {
  const m = $("method").value;
  document.querySelectorAll(".qm-only").forEach((e) => e.classList.toggle("hidden", m !== "qmarkov"));
  document.querySelectorAll(".sub-only").forEach((e) => e.classList.toggle("hidden", m === "qmarkov"));
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

function channelBoxes(info) {
  const fill = (boxId, legend, selected) => {
    const box = $(boxId);
    box.innerHTML = "<legend>" + legend + "</legend>";
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

function setup(info) {
  state.info = info;
  state.order = "auto";
  $("data-name").textContent = info.name + ": " + info.rows + " rows, T = " + info.ts + " s, columns " +
    info.columns.map((c) => c.name).join(", ");
  channelBoxes(info);
  $("save-model").classList.add("disabled");
  $("save-report").classList.add("disabled");
  schedule({ view: true, identify: true });
}

async function loadFile(file) {
  clearError();
  setStatus("loading " + file.name + "…");
  try {
    const buf = await file.arrayBuffer();
    const info = await call("/api/data?name=" + encodeURIComponent(file.name), buf);
    setup(info);
  } catch (e) {
    setStatus("no data");
    showError(e.message);
  }
}

function renderView(v) {
  $("fig-inputs").innerHTML = v.inputs_svg;
  $("fig-outputs").innerHTML = v.outputs_svg;
  const rows = ["<tr><th>channel</th><th>kind</th><th>period</th><th>samples</th></tr>"];
  for (const c of v.inputs) rows.push("<tr><td>" + esc(c.name) + "</td><td>input</td><td>hold " + c.period + " T</td><td>" + c.samples + "</td></tr>");
  for (const c of v.outputs) rows.push("<tr><td>" + esc(c.name) + "</td><td>output</td><td>" + c.period + " T</td><td>" + c.samples + "</td></tr>");
  $("rates").innerHTML = rows.join("");
  state.views += 1;
  $("status").dataset.view = String(state.views);
}

function esc(s) {
  return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;");
}

function renderIdentified(r) {
  const sel = r.order_selection;
  const slider = $("order-slider");
  if (sel && sel.values.length > 0) {
    slider.max = String(Math.max(1, Math.min(sel.values.length, 60)));
    $("order-kind").textContent = sel.kind + (sel.suggested_order ? "; largest gap at order " + sel.suggested_order : "");
  } else {
    slider.max = String(Math.max(10, r.order));
    $("order-kind").textContent = "";
  }
  slider.disabled = false;
  slider.value = String(r.order);
  $("order-value").textContent = state.order === "auto" ? r.order + " (auto)" : String(r.order);
  $("fig-order").innerHTML = r.figures.order || "<p class=\"note\">This route gives no order-selection values.</p>";
  const fits = ["<tr><th>output</th><th>fit % (simulation)</th><th>white residual</th><th>independent of u</th></tr>"];
  for (const f of r.fits) {
    fits.push("<tr><td>" + esc(f.output) + "</td><td class=\"fit\" data-output=\"" + esc(f.output) + "\">" +
      f.fit.toFixed(2) + "</td><td>" + (f.white ? "yes" : "no") + "</td><td>" + (f.independent ? "yes" : "no") + "</td></tr>");
  }
  $("fits").innerHTML = fits.join("");
  $("fig-response").innerHTML = r.figures.response.join("");
  $("fig-error").innerHTML = r.figures.error.join("");
  $("fig-step").innerHTML = r.figures.step;
  $("fig-bode").innerHTML = r.figures.bode;
  $("fig-pz").innerHTML = r.figures.pz;
  $("command").textContent = r.command;
  $("save-model").classList.remove("disabled");
  $("save-report").classList.remove("disabled");
  state.generation += 1;
  $("status").dataset.generation = String(state.generation);
  setStatus(r.method + ", order " + r.order + " — " + r.elapsed_ms.toFixed(0) + " ms");
}

// One request at a time; while one runs, only the latest of the requests
// made meanwhile is kept (a slider drag sends far fewer calls than events).
function schedule(job) {
  if (!state.info) return;
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
      renderIdentified(await call("/api/identify", JSON.stringify(request(true))));
    }
  } catch (e) {
    showError(e.message);
    setStatus("error");
  }
  state.busy = false;
  $("status").dataset.busy = "0";
  const next = state.pending;
  state.pending = null;
  if (next) run(next);
}

function wire() {
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
  for (const id of ["horizon", "prbs-order", "amplitude", "output-weight", "instrument", "detrend", "stable"]) {
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
    const info = await call("/api/data");
    if (info) setup(info);
  } catch (e) {
    showError(e.message);
  }
});
