//! Identification in a session: the request made explicit, the identify
//! arguments built field by field, the model made (or taken from the
//! session's caches), validated on the estimation or validation record,
//! its figures drawn; the last model's file and report.

use std::time::Instant;

use lifted_lti::{Dataset, ModelFile};
use lifted_workflow::Diagnostics;

use crate::args::{DetrendArg, IdentifyArgs};
use crate::error::{CliResult, Context, clap_one_line, input};
use crate::plot::svg;
use crate::service::bands;
use crate::service::figures::{
    bode_grid, criterion_plot, order_plot, pz_plot, residual_plots, response_error_plot_in,
    response_plot_in, stack_svgs, step_data,
};
use lifted_workflow::WorkflowOptions;

use crate::service::identify::{
    files_from_args, identify_files_with, options_from_args, options_of_plan, require_stable,
};
use crate::service::pairs::{PairFigure, add_empirical_pairs, bode_pairs, pairs_svg, step_pairs};
use crate::service::report::render;
use crate::service::validation::{validate_model_at, with_detrend};

use super::*;

impl Session {
    /// The `lifted identify` arguments of a request (without `lifted`).
    pub(super) fn identify_words(r: &Request, data: &[String], out: &str) -> Vec<String> {
        let mut w: Vec<String> = vec!["identify".into()];
        // A value that starts with '-' is attached (`--flag=-1`): clap
        // would take it for an option.
        let mut opt = |flag: &str, v: String| {
            if v.starts_with('-') {
                w.push(format!("--{flag}={v}"));
            } else {
                w.push(format!("--{flag}"));
                w.push(v);
            }
        };
        if r.plan.is_none() {
            opt("method", r.method.clone().unwrap_or_else(|| "n4sid".into()));
        }
        for d in data {
            opt("data", d.clone());
        }
        opt("inputs", r.inputs.join(","));
        opt("outputs", r.outputs.join(","));
        if let Some(ts) = r.ts {
            opt("ts", ts.to_string());
        }
        if r.plan.is_none()
            && let Some(h) = r.hold
        {
            opt("hold", h.to_string());
        }
        for p in &r.output_period {
            opt("output-period", p.clone());
        }
        if r.plan.is_some() {
            // The options are the plan's (`lifted identify --plan`): the
            // option flags stay at their defaults.
            opt("plan", "plan.json".into());
            w.push("--out".into());
            w.push(out.into());
            return w;
        }
        if let Some(o) = &r.order {
            opt("order", o.clone());
        }
        if let Some(o) = &r.orders {
            opt("orders", o.clone());
        }
        if let Some(p) = &r.process {
            opt("process", p.clone());
        }
        if let Some(k) = &r.kernel {
            opt("kernel", k.clone());
        }
        if let Some(k) = &r.a_structure {
            opt("a-structure", k.clone());
        }
        if let Some(k) = &r.f_structure {
            opt("f-structure", k.clone());
        }
        if let Some(i) = &r.intersample {
            opt("intersample", i.clone());
        }
        let num = |v: Option<usize>| v.map(|x| x.to_string());
        for (flag, v) in [
            ("max-order", num(r.max_order)),
            ("horizon", num(r.horizon)),
            ("q", num(r.q)),
            ("prbs-order", r.prbs_order.map(|x| x.to_string())),
            ("amplitude", r.amplitude.map(|x| x.to_string())),
            ("detrend", r.detrend.clone()),
            ("estimator", r.estimator.clone()),
            ("order-criterion", r.order_criterion.clone()),
            // The page refines only on its PEM button: a slider move stays a
            // subspace fit (the command's default, `auto`, would refine).
            (
                "refine",
                Some(r.refine.clone().unwrap_or_else(|| "none".into())),
            ),
        ] {
            if let Some(v) = v {
                opt(flag, v);
            }
        }
        if !r.output_weight.is_empty() {
            let s: Vec<String> = r.output_weight.iter().map(f64::to_string).collect();
            opt("output-weight", s.join(","));
        }
        if !r.instrument.is_empty() {
            opt("instrument", r.instrument.join(","));
        }
        if let Some(d) = r.feedthrough {
            opt("feedthrough", d.to_string());
        }
        if r.stable {
            w.push("--stable".into());
        }
        w.push("--out".into());
        w.push(out.into());
        w
    }

    /// The request as the command's arguments, built field by field from
    /// its typed values (no command line written and parsed again): the
    /// command's defaults, then each value the request gives — the same
    /// arguments the shown command line parses to (test
    /// `the_request_builds_the_shown_command_s_arguments`). A name the
    /// command does not take (method, detrend, estimator, order criterion,
    /// refinement) is an error naming the field and the names it takes.
    pub(super) fn identify_args(r: &Request, data: &[String]) -> CliResult<IdentifyArgs> {
        fn named<T: clap::ValueEnum>(field: &str, value: &str) -> CliResult<T> {
            T::from_str(value, false).map_err(|_| {
                let names: Vec<String> = T::value_variants()
                    .iter()
                    .filter_map(|v| v.to_possible_value())
                    .map(|v| format!("'{}'", v.get_name()))
                    .collect();
                input(format!(
                    "invalid {field} '{value}' (one of {})",
                    names.join(", ")
                ))
            })
        }
        let mut a = Self::default_identify_args()?;
        a.data = data.to_vec();
        a.columns.inputs = Some(r.inputs.join(","));
        a.columns.outputs = Some(r.outputs.join(","));
        a.columns.ts = r.ts;
        a.columns.output_period = r.output_period.clone();
        a.out = "model.json".into();
        if r.plan.is_some() {
            // The options come from the plan (`Session::options_of`).
            a.plan = Some("plan.json".into());
            return Ok(a);
        }
        a.method = named("method", r.method.as_deref().unwrap_or("n4sid"))?;
        if let Some(h) = r.hold {
            a.hold = h;
        }
        if let Some(o) = &r.order {
            a.order = o.clone();
        }
        a.orders = r.orders.clone();
        if let Some(p) = &r.process {
            a.process = Some(named("process", p)?);
        }
        if let Some(k) = &r.kernel {
            a.kernel = Some(named("kernel", k)?);
        }
        if let Some(k) = &r.a_structure {
            a.a_structure = Some(named("a_structure", k)?);
        }
        if let Some(k) = &r.f_structure {
            a.f_structure = Some(named("f_structure", k)?);
        }
        if let Some(i) = &r.intersample {
            a.intersample = Some(named("intersample", i)?);
        }
        if let Some(m) = r.max_order {
            a.max_order = m;
        }
        a.horizon = r.horizon.or(a.horizon);
        a.q = r.q.or(a.q);
        a.prbs_order = r.prbs_order.or(a.prbs_order);
        if let Some(x) = r.amplitude {
            a.amplitude = vec![x];
        }
        if let Some(d) = &r.detrend {
            a.detrend = named("detrend", d)?;
        }
        if let Some(e) = &r.estimator {
            a.estimator = named("estimator", e)?;
        }
        if let Some(c) = &r.order_criterion {
            a.order_criterion = named("order_criterion", c)?;
        }
        // The page refines only on its PEM button: a slider move stays a
        // subspace fit (the command's default, `auto`, would refine).
        a.refine = named("refine", r.refine.as_deref().unwrap_or("none"))?;
        if !r.output_weight.is_empty() {
            a.output_weight = r.output_weight.clone();
        }
        if !r.instrument.is_empty() {
            a.instrument = Some(r.instrument.join(","));
        }
        a.feedthrough = r.feedthrough.or(a.feedthrough);
        a.stable = r.stable;
        Ok(a)
    }

    /// The workflow options of a request: its plan's
    /// (`lifted_workflow::options_from_plan`, as `lifted identify --plan`
    /// reads a plan file), else those of its arguments.
    pub(super) fn options_of(r: &Request, a: &IdentifyArgs) -> CliResult<WorkflowOptions> {
        match &r.plan {
            Some(plan) => options_of_plan(plan, "plan"),
            None => options_from_args(a),
        }
    }

    /// `lifted identify`'s arguments at their defaults (the parser's
    /// defaults, from a command line of constants).
    pub(super) fn default_identify_args() -> CliResult<IdentifyArgs> {
        IdentifyArgs::defaults("model.json")
            .map_err(|e| input(clap_one_line(&e).trim_start_matches("error: ")))
    }

    /// The model file of a request, as `lifted identify` writes it: the
    /// command's own identification, with the record and the compression of
    /// its in-memory route kept between requests ([`Cache`]).
    pub(super) fn model_file(&mut self, r: &Request) -> CliResult<ModelFile> {
        let paths: Vec<String> = self
            .estimation_sources(r)?
            .into_iter()
            .map(|(_, p)| p.display().to_string())
            .collect();
        let key = Self::identification_key(r, &paths);
        if let Some(file) = self.cache.identification(&key) {
            return Ok(file);
        }
        let a = Self::identify_args(r, &paths)?;
        let (files, opts) = (files_from_args(&a)?, Self::options_of(r, &a)?);
        let file =
            identify_files_with(&files, &opts, &mut self.cache).map_err(|e| self.plain(e))?;
        if a.stable || opts.validation.require_stable {
            require_stable(&file.model)?;
        }
        self.cache.keep_identification(key, file.clone());
        Ok(file)
    }

    /// What tells identifications apart for the kept ones (the module
    /// `cached`): the command line (every option and data file) and the
    /// ranges the data files were cut from.
    pub(super) fn identification_key(r: &Request, paths: &[String]) -> String {
        let words = Self::identify_words(r, paths, "model.json");
        format!(
            "{}\u{1f}{:?}\u{1f}{:?}\u{1f}{}",
            words.join("\u{1f}"),
            r.estimation_range,
            r.validation_range,
            r.plan.as_ref().map(|p| p.to_string()).unwrap_or_default()
        )
    }

    /// The request with the options the page leaves to the defaults made
    /// explicit where that keeps the command on the studio's fast route
    /// (the command line shown then takes the same route, see the module `cached`):
    /// for a numeric order of single-rate N4SID/MOESP/CVA, the horizon
    /// (10, or the least that holds the order), the (A, C) route (shift invariance) and, when no output period
    /// is declared, period 1 for every output (the record's complete
    /// columns: the command then identifies in memory, not streamed); for
    /// a record without a time column, the base period (1 s).
    pub fn explicit(&self, r: &Request) -> CliResult<Request> {
        let rec = self.record()?;
        let mut r = r.clone();
        if r.ts.is_none() && !rec.info.has_time {
            r.ts = Some(1.0);
        }
        if r.plan.is_some() {
            // The plan's options are the model's: nothing to make explicit.
            return Ok(r);
        }
        let subspace = matches!(
            r.method.as_deref().unwrap_or("n4sid"),
            "n4sid" | "moesp" | "cva"
        );
        let numeric = r
            .order
            .as_deref()
            .is_some_and(|o| o.trim().parse::<usize>().is_ok_and(|n| n > 0));
        let complete = |name: &String| {
            rec.info
                .columns
                .iter()
                .any(|c| &c.name == name && c.samples == rec.info.rows)
        };
        let single_rate = r.outputs.iter().all(complete) && r.hold.unwrap_or(1) <= 1;
        if subspace && numeric && single_rate && r.instrument.is_empty() && r.refine.is_none() {
            // The command's default horizon 10, or the least one that holds
            // the order ((i − 1) n_y ≥ n).
            let n = r
                .order
                .as_deref()
                .and_then(|o| o.trim().parse::<usize>().ok())
                .unwrap_or(1);
            let ny = r.outputs.len().max(1);
            r.horizon.get_or_insert(10.max(n.div_ceil(ny) + 1));
            r.estimator.get_or_insert_with(|| "shift".into());
            if r.output_period.is_empty() {
                r.output_period = r.outputs.iter().map(|o| format!("{o}=1")).collect();
            }
        }
        Ok(r)
    }

    /// The record of a request checked against a model file, as `lifted
    /// validate --detrend auto` does; `horizons`: the prediction fits'
    /// ([`SLIDER_HORIZONS`] for what the page shows, [`REPORT_HORIZONS`]
    /// for the report's table).
    pub(crate) fn validated(
        &mut self,
        file: &ModelFile,
        r: &Request,
        horizons: &[usize],
    ) -> CliResult<(ModelFile, Dataset, crate::service::validation::Validation)> {
        let (name, path, folder) = self.validation_source(r)?;
        let paths: Vec<String> = self
            .estimation_sources(r)?
            .into_iter()
            .map(|(_, p)| p.display().to_string())
            .collect();
        // The model's matrices too: the key then tells apart any two
        // models given with one request.
        let matrices = {
            use std::hash::{Hash, Hasher};
            let m = &file.model;
            let mut h = std::collections::hash_map::DefaultHasher::new();
            for x in [m.a(), m.b(), m.c(), m.d()] {
                x.shape().hash(&mut h);
                x.iter().for_each(|v| v.to_bits().hash(&mut h));
            }
            h.finish()
        };
        let key = format!(
            "{}\u{1f}{}\u{1f}{}\u{1f}{matrices:x}\u{1f}{horizons:?}",
            Self::identification_key(r, &paths),
            name,
            path.display()
        );
        if let Some(kept) = self.cache.validation(&key) {
            return Ok(kept);
        }
        let data = self
            .load_from(&path.display().to_string(), &folder, r)?
            .clone();
        let (file, data) = with_detrend(file.clone(), data, DetrendArg::Auto, &name)?;
        let shortest = data
            .outputs()
            .iter()
            .map(|c| data.len() / c.period.max(1))
            .min()
            .unwrap_or(0);
        let lags = LAGS.min(shortest.saturating_sub(1) / 4).max(1);
        // The page shows the simulation fits, the residual tests (on the
        // simulation's residuals) and the one-step prediction fits.
        let v = validate_model_at(
            &file,
            &data,
            lags,
            lifted_lti::InitialCondition::Estimate,
            horizons,
            &name,
        )?;
        let validated = (file, data, v);
        self.cache.keep_validation(key, validated.clone());
        Ok(validated)
    }

    /// Refuses a request whose sizes the record cannot support, before
    /// anything is allocated: a horizon i whose block Hankel matrix (past +
    /// future = 2i block rows of n_u + n_y rows each) would have more rows
    /// than the record has samples, or whose k² working matrix would pass
    /// [`MAX_WORK_BYTES`]; a q, order or largest order beyond the record's
    /// length or that bound; a hold longer than the record. (A lifted,
    /// multirate record needs at least as many rows, so the bound never
    /// refuses a request the identification could have served.)
    pub fn check_sizes(&self, r: &Request) -> CliResult<()> {
        let rec = self.record()?;
        let (rows, name) = (rec.info.rows, rec.name.as_str());
        let channels = (r.inputs.len() + r.outputs.len()).max(1) as u128;
        // The selected channels of the record, read for the request, and
        // the copies an identification makes of them (scaled, deviations,
        // simulated, residuals: RECORD_COPIES in all) within the memory
        // budget (`lifted studio --memory-limit`, LIFTED_MEMORY_LIMIT,
        // default half the physical memory).
        let budget = lifted_linalg::budget::MemoryBudget::default().bytes() as u128;
        let record_bytes = rows as u128 * channels * 8 * RECORD_COPIES;
        if record_bytes > budget {
            return Err(input(format!(
                "{name}: {rows} rows of the {channels} channels chosen need about {} of memory \
                 for an identification, more than the studio's budget of {} (lifted studio \
                 --memory-limit, or LIFTED_MEMORY_LIMIT): choose fewer channels or raise the budget",
                bytes_text(record_bytes as f64),
                bytes_text(budget as f64)
            )));
        }
        let memory = |flag: &str, value: usize, k: u128, what: &str| -> CliResult<()> {
            let bytes = 8 * k * k;
            if bytes > MAX_WORK_BYTES as u128 {
                return Err(input(format!(
                    "{flag} {value} is too large: the {what} ({k} rows) would need {} of memory \
                     (the studio's limit is {})",
                    bytes_text(bytes as f64),
                    bytes_text(MAX_WORK_BYTES as f64)
                )));
            }
            Ok(())
        };
        if let Some(h) = r.horizon {
            let k = 2 * h as u128 * channels;
            if k > rows as u128 {
                return Err(input(format!(
                    "horizon {h} is too large for {name}: the block Hankel matrix would have \
                     {k} rows (2 × {h} × {channels} channels), more than the record's {rows} samples"
                )));
            }
            memory("horizon", h, k, "block Hankel matrix")?;
        }
        let numeric_order = r
            .order
            .as_deref()
            .and_then(|o| o.trim().parse::<usize>().ok());
        for (flag, v) in [
            ("q", r.q),
            ("order", numeric_order),
            ("max_order", r.max_order),
            ("hold", r.hold),
        ] {
            let Some(v) = v else { continue };
            if v > rows {
                return Err(input(format!(
                    "{flag} {v} is too large for {name}: more than the record's {rows} samples"
                )));
            }
            match flag {
                "q" => memory(flag, v, v as u128 * channels, "q-Markov data matrix")?,
                "order" | "max_order" => memory(flag, v, v as u128, "state matrix")?,
                _ => {}
            }
        }
        Ok(())
    }

    /// Identifies with the request's options, validates on the record and
    /// draws the figures; the model is kept for [`Session::model_json`] and
    /// [`Session::report`]. A failed identification leaves no model (the
    /// previous ones are dropped: saving after a failure is an error, not the
    /// model of other options).
    pub fn identify(&mut self, r: &Request) -> CliResult<Identified> {
        let out = self.identified(r);
        if out.is_err() {
            self.models.clear();
        }
        out
    }

    pub(super) fn identified(&mut self, r: &Request) -> CliResult<Identified> {
        let start = Instant::now();
        self.check_sizes(r)?;
        let r = &self.explicit(r)?;
        self.check_sizes(r)?;
        let (data_name, data_path) = self.estimation_source(r)?;
        let names: Vec<String> = self
            .estimation_sources(r)?
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        let words = Self::identify_words(r, &names, "model.json");
        let command = std::iter::once("lifted".to_string())
            .chain(words)
            .map(|w| shell_word(&w))
            .collect::<Vec<_>>()
            .join(" ");
        let file = self.model_file(r)?;
        let model = &file.model;
        let diagnostics = Diagnostics::of(&file);
        // The bands of a model with a covariance (`service::bands`), at the
        // page's level.
        let confidence = r.confidence.unwrap_or(bands::DEFAULT_CONFIDENCE);
        bands::check_level(confidence)?;
        let uncertain = bands::Uncertain::of(&file);
        // The model's own figures (step, pole-zero map, Bode curves,
        // transfer functions) on a second thread while the model is
        // validated on the record (simulation and residual tests).
        type ModelFigures = (String, String, PairFigure, (Vec<ChannelTf>, Option<String>));
        let (validated, drawn) = std::thread::scope(|scope| {
            let drawn = scope.spawn(|| -> CliResult<ModelFigures> {
                let omega = bode_grid(model, None, None, 200)?;
                let one = [(String::new(), model)];
                let mut step = step_pairs(&one)?;
                let mut bode = bode_pairs(&one, &omega)?;
                if uncertain.is_some() && confidence > 0.0 {
                    let (t, cols) = step_data(model, None, None)?;
                    if let Some(b) = bands::step_bounds(uncertain, &cols, confidence)? {
                        bands::add_step_band(&mut step, &t, &b, confidence);
                    }
                    let response = model.bode(&omega).ctx("bode")?;
                    if let Some(b) = bands::bode_bounds(uncertain, &response, &omega, confidence)? {
                        bands::add_bode_band(&mut bode, &omega, &b, confidence);
                    }
                }
                Ok((
                    pairs_svg(&step, 560, 240)?,
                    svg(&pz_plot(model)?, 380, 440)?,
                    bode,
                    channel_tfs(model),
                ))
            });
            let validated = self.validated(&file, r, SLIDER_HORIZONS);
            let drawn = drawn
                .join()
                .unwrap_or_else(|_| Err(input("internal: drawing the model's figures failed")));
            (validated, drawn)
        });
        let (_, data, v) = validated?;
        let (step, pz, mut bode, (transfer_functions, transfer_note)) = drawn?;
        let ts = data.ts();
        let n = data.len();
        let mut response = Vec::new();
        let mut error = Vec::new();
        let window = window_of(r)?;
        let mut residuals = Vec::new();
        for o in &v.outputs {
            response.push(svg(
                &response_plot_in(o, ts, n, v.stable(), window),
                900,
                260,
            )?);
            error.push(svg(&response_error_plot_in(o, ts, window), 900, 160)?);
            let (auto, cross) = residual_plots(o, &r.inputs);
            residuals.push(stack_svgs(
                &svg(&auto, 450, 220)?,
                &svg(&cross, 450, 220)?,
                450,
                220,
            ));
        }
        if data.is_single_rate()
            && let Some(g) = self.cache.spectral(&data)
        {
            add_empirical_pairs(&mut bode, g);
        }
        let figures = Figures {
            order: order_plot(&diagnostics)
                .map(|p| svg(&p, 560, 280))
                .transpose()?,
            response,
            error,
            residuals,
            step,
            bode: pairs_svg(&bode, 560, 200)?,
            pz,
            criterion: criterion_plot(&diagnostics)
                .map(|p| svg(&p, 560, 280))
                .transpose()?,
        };
        let (figures, figure_digests, unchanged) = figures.unsent(&r.have);
        let order_selection = diagnostics
            .order_selection
            .as_ref()
            .map(|os| OrderSelection {
                kind: os.kind.clone(),
                values: os.values.clone(),
                order: model.order(),
                suggested_order: Some(os.suggested_order),
            });
        let poles = model
            .poles()
            .map(|p| p.iter().map(|z| (z.re, z.im)).collect())
            .unwrap_or_default();
        let stable = v.stable();
        let fits = v
            .outputs
            .iter()
            .map(|o| Fit {
                output: o.name.clone(),
                fit: (stable && o.residual_finite && o.fit.is_finite()).then_some(o.fit),
                stable,
                white: o.white,
                independent: o.independent,
                one_step: o
                    .prediction_fits
                    .first()
                    .copied()
                    .filter(|f| stable && o.residual_finite && f.is_finite()),
            })
            .collect();
        let chosen = diagnostics.structure_selection.as_ref();
        let horizon = chosen.and_then(|c| c.horizon).or(r.horizon);
        let estimator = chosen
            .and_then(|c| c.system.as_deref())
            .map(|s| {
                if s.starts_with("shift") {
                    "shift".to_string()
                } else {
                    "states".to_string()
                }
            })
            .or_else(|| r.estimator.clone());
        let out = Identified {
            parameters: crate::service::identify::parameters_text(&file, &diagnostics, true),
            matrices: Matrices {
                a: rows_of(model.a()),
                b: rows_of(model.b()),
                c: rows_of(model.c()),
                d: rows_of(model.d()),
                k: file.kalman_gain.clone(),
            },
            transfer_functions,
            transfer_note,
            refinement: diagnostics.refinement.as_ref().map(|refinement| {
                // How it was judged (held-out blocks or the record).
                let mut v = serde_json::to_value(refinement).unwrap_or_default();
                if let (Some(obj), Some(j)) = (v.as_object_mut(), &diagnostics.refinement_judge) {
                    obj.insert("judge".into(), serde_json::to_value(j).unwrap_or_default());
                }
                v
            }),
            gain: diagnostics.kalman_gain_route.clone(),
            validation_data: self.validation_source(r)?.0,
            seq: r.seq,
            horizon,
            estimator,
            stable,
            spectral_radius: v.spectral_radius.is_finite().then_some(v.spectral_radius),
            command,
            method: file.method.clone().unwrap_or_default(),
            order: model.order(),
            order_selection,
            fits,
            poles,
            feedback: diagnostics.feedback.as_ref().and_then(|f| f.summary()),
            warnings: diagnostics.warnings.clone(),
            figures,
            figure_digests,
            unchanged,
            elapsed_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        if self.models.len() >= KEPT_MODELS {
            self.models.remove(0);
        }
        self.models.push(Last {
            seq: r.seq,
            file,
            request: r.clone(),
            command: out.command.clone(),
            data: (data_name, data_path),
        });
        Ok(out)
    }

    /// The model of the request numbered `seq`, or the last one.
    pub(super) fn last(&self, seq: Option<u64>) -> CliResult<&Last> {
        let Some(last) = self.models.last() else {
            return Err(input("no model yet: identify one first"));
        };
        match seq {
            None => Ok(last),
            Some(s) => self
                .models
                .iter()
                .rev()
                .find(|m| m.seq == Some(s))
                .ok_or_else(|| {
                    input(format!(
                        "no model of request {s}: the studio keeps the last {KEPT_MODELS} \
                         models of the current options"
                    ))
                }),
        }
    }

    /// The model of request `seq` (the last model without one) as the
    /// command's model-file JSON.
    pub fn model_json(&self, seq: Option<u64>) -> CliResult<String> {
        self.last(seq)?
            .file
            .to_json()
            .map_err(|e| input(format!("model file: {e}")))
    }

    /// The plan of the model of request `seq` (the last model without
    /// one): the workflow options it was made with, as `lifted identify
    /// --write-plan` writes them, for `--plan` or the page's plan.
    pub fn plan_json(&self, seq: Option<u64>) -> CliResult<String> {
        let options = Diagnostics::of(&self.last(seq)?.file)
            .options
            .ok_or_else(|| input("the model file carries no options"))?;
        serde_json::to_string_pretty(&options)
            .map(|s| s + "\n")
            .map_err(|e| input(format!("plan: {e}")))
    }

    /// The report page of the model of request `seq` (the last model
    /// without one) on the record.
    pub fn report(&mut self, seq: Option<u64>) -> CliResult<String> {
        let last = self.last(seq)?;
        let (file, request) = (last.file.clone(), last.request.clone());
        let name = self.record()?.name.clone();
        let (file, data, v) = self.validated(&file, &request, REPORT_HORIZONS)?;
        render(&file, &data, &v, "model.json (lifted studio)", &name)
    }
}
