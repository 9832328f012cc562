//! What the studio's page and its session exchange: the request (the
//! identify options as the page sets them) and the answers (data
//! information, channel views, an identification with its figures, the
//! delays between pairs). Serialised as JSON by the server.

use serde::{Deserialize, Serialize};

/// Identification and view options of the page, named as the options of
/// `lifted identify` (`output_period` entries are `NAME=PERIOD`; `order` is a
/// positive integer or `auto`). Absent fields take the command's defaults.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Request {
    /// Input column names.
    pub inputs: Vec<String>,
    /// Output column names.
    pub outputs: Vec<String>,
    /// Base period in seconds (default: from the time column, else 1).
    pub ts: Option<f64>,
    /// Input hold n_r in base periods.
    pub hold: Option<usize>,
    /// Declared output periods, `NAME=PERIOD`.
    pub output_period: Vec<String>,
    /// `qmarkov`, `n4sid`, `moesp`, `cva` or `iv` (multirate records take
    /// the multirate route of the subspace and IV methods).
    pub method: Option<String>,
    /// Model order, or `auto`.
    pub order: Option<String>,
    /// Polynomial models (`arx`, `fir`, `oe`, `armax`, `bj`): MATLAB's
    /// order vector, as `lifted identify --orders` takes it ("2 2 1").
    pub orders: Option<String>,
    /// Process models (`process`): the structure (`p1d`, `p2d`, `p1di`,
    /// `p2dz`, `p2du`), as `--process`.
    pub process: Option<String>,
    /// Regularised models (`impulse`, and `arx` for MATLAB's arxRegul):
    /// the prior's kernel, `tc` or `dc`, as `--kernel`.
    pub kernel: Option<String>,
    /// ARX of several outputs: the pattern of A, `full` or `diagonal`, as
    /// `--a-structure`.
    pub a_structure: Option<String>,
    /// OE and BJ: the denominators, `per-input` or `common`, as
    /// `--f-structure`.
    pub f_structure: Option<String>,
    /// Process models: how the inputs move between samples, `zoh` or
    /// `foh`, as `--intersample`.
    pub intersample: Option<String>,
    /// Largest order of `auto`.
    pub max_order: Option<usize>,
    /// Horizon (subspace i, IV α).
    pub horizon: Option<usize>,
    /// q-Markov: q.
    pub q: Option<usize>,
    /// q-Markov: PRBS order n.
    pub prbs_order: Option<u32>,
    /// q-Markov: PRBS magnitude.
    pub amplitude: Option<f64>,
    /// q-Markov: diagonal output weighting Q.
    pub output_weight: Vec<f64>,
    /// IV: instrument columns.
    pub instrument: Vec<String>,
    /// A plan: the identification options of a model file, its
    /// diagnostics or a `--write-plan` file, as `lifted identify --plan`
    /// takes them. The options then come from the plan, every option field
    /// above is left unused (the data fields are used), and the command
    /// line shown says `--plan plan.json`.
    pub plan: Option<serde_json::Value>,
    /// `auto`, `mean`, `linear` or `none`.
    pub detrend: Option<String>,
    /// `shift` or `states`.
    pub estimator: Option<String>,
    /// `gap`, `svc`, `aic`, `aicc` or `bic`.
    pub order_criterion: Option<String>,
    /// Enforce a stable model.
    pub stable: bool,
    /// Estimate a direct feedthrough D (`true`) or fix D = 0 (`false`);
    /// absent: the method's default (`lifted identify --feedthrough`).
    pub feedthrough: Option<bool>,
    /// The page's sequence number of this request (not an option of
    /// `lifted identify`): echoed in the answer, and the key under which
    /// the model is kept for `GET /api/model?seq=`.
    pub seq: Option<u64>,
    /// The rows of the estimation record to identify on, `[t0, t1]` in
    /// seconds (absent: all); see [`crate::studio::ranges`].
    pub estimation_range: Option<[f64; 2]>,
    /// The rows of the validation data (the validation record, else the
    /// estimation record) the model is checked on, `[t0, t1]` seconds.
    pub validation_range: Option<[f64; 2]>,
    /// `pem` or `oe`: refine the model (Levenberg–Marquardt on the
    /// prediction or simulation error, `lifted identify --refine`).
    pub refine: Option<String>,
    /// The time window `[t0, t1]` (seconds) of the time plots: the page's
    /// zoom (not an option of `lifted identify`; absent: the whole record).
    pub window: Option<[f64; 2]>,
    /// The level of the confidence bands on the step and Bode figures of a
    /// model with a covariance (not an option of `lifted identify`: the
    /// plots' `--confidence`; absent: 0.95; 0: no band).
    pub confidence: Option<f64>,
    /// The figures the page shows, by slot (`response`, `bode`, …) with
    /// the digest an earlier answer gave them (`Identified::figure_digests`;
    /// not an option of `lifted identify`): a figure whose digest is the
    /// same is not sent again (its slot is listed in
    /// `Identified::unchanged`, its content left empty).
    pub have: std::collections::BTreeMap<String, String>,
}

/// One column of an uploaded record.
#[derive(Debug, Clone, Serialize)]
pub struct ColumnInfo {
    /// Header name.
    pub name: String,
    /// Non-empty cells.
    pub samples: usize,
    /// Spacing of its samples in rows (1: every row), when regular.
    pub period: Option<usize>,
}

/// What the page learns of an uploaded record.
#[derive(Debug, Clone, Serialize)]
pub struct DataInfo {
    /// File name as uploaded.
    pub name: String,
    /// Data rows.
    pub rows: usize,
    /// Base period (time column, else 1).
    pub ts: f64,
    /// Whether the file has a time column (`t` or `time`); without one the
    /// base period is the page's field (1 s when empty, `--ts 1` on the
    /// command line).
    pub has_time: bool,
    /// The columns other than the time column.
    pub columns: Vec<ColumnInfo>,
    /// Columns proposed as inputs: complete columns whose names say so
    /// (`named_role`: `u…`, `r…`, plant tags ending `.OP`/`.MV`), else
    /// the first complete one.
    pub suggested_inputs: Vec<String>,
    /// Columns proposed as outputs: those whose names say so (`y…`, tags
    /// ending `.PV`/`.CV`), else the columns not proposed as inputs.
    pub suggested_outputs: Vec<String>,
    /// The proposal is a guess (no naming convention decided the inputs or
    /// the outputs): the page asks the user to confirm the channels before
    /// it identifies.
    pub channels_guessed: bool,
}

/// A channel and its rate, for the page.
#[derive(Debug, Clone, Serialize)]
pub struct Channel {
    /// Name.
    pub name: String,
    /// Hold (inputs) or sampling period (outputs) in base periods.
    pub period: usize,
    /// Samples of the channel in the record.
    pub samples: usize,
}

/// The record as selected: channels, rates and the signal plots.
#[derive(Debug, Clone, Serialize)]
pub struct View {
    /// Data rows.
    pub rows: usize,
    /// Base period.
    pub ts: f64,
    /// Inputs with their holds.
    pub inputs: Vec<Channel>,
    /// Outputs with their sampling periods.
    pub outputs: Vec<Channel>,
    /// SVG of the inputs.
    pub inputs_svg: String,
    /// SVG of the outputs (slow outputs as markers).
    pub outputs_svg: String,
}

/// Order-selection data of the model file.
#[derive(Debug, Clone, Serialize)]
pub struct OrderSelection {
    /// What the values are (singular values, Λ diagonal).
    pub kind: String,
    /// The values, largest first.
    pub values: Vec<f64>,
    /// The order of the model.
    pub order: usize,
    /// The order the gap rule suggests.
    pub suggested_order: Option<usize>,
}

/// One output's simulation fit.
#[derive(Debug, Clone, Serialize)]
pub struct Fit {
    /// Output name.
    pub output: String,
    /// Fit % (100 (1 − ‖y − ŷ‖/‖y − ȳ‖), simulated from the initial state
    /// fitted to the record by least squares); `null`
    /// when it is not meaningful: an unstable model (its simulation
    /// diverges), a non-finite residual or a constant output.
    pub fit: Option<f64>,
    /// Whether the model is stable (ρ(A) < 1); when not, the page shows
    /// "n/a: unstable" for the fit.
    pub stable: bool,
    /// Whether the residual is white.
    pub white: bool,
    /// Whether the residual is independent of the inputs.
    pub independent: bool,
    /// One-step prediction fit % with the model's Kalman gain (the
    /// predictor started from the simulation's initial state); `null`
    /// without a gain or when the simulation fit is not meaningful.
    pub one_step: Option<f64>,
}

/// The model's matrices, one inner vector per row.
#[derive(Debug, Clone, Serialize)]
pub struct Matrices {
    /// A (n × n).
    pub a: Vec<Vec<f64>>,
    /// B (n × m).
    pub b: Vec<Vec<f64>>,
    /// C (p × n).
    pub c: Vec<Vec<f64>>,
    /// D (p × m).
    pub d: Vec<Vec<f64>>,
    /// The Kalman gain K (n × p) of the innovations form, when the route
    /// gives one.
    pub k: Option<Vec<Vec<f64>>>,
}

/// One channel's transfer function G_ij(z) = num(z)/den(z) (positive
/// powers of z, minimal realisation of the channel).
#[derive(Debug, Clone, Serialize)]
pub struct ChannelTf {
    /// Output name.
    pub output: String,
    /// Input name.
    pub input: String,
    /// Numerator, as text (`0.5 z - 0.2`).
    pub num: String,
    /// Denominator, as text.
    pub den: String,
}

/// The figures of an identification, as SVG documents.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Figures {
    /// Order selection (log scale, chosen order marked).
    pub order: Option<String>,
    /// Per output: measured and simulated response.
    pub response: Vec<String>,
    /// Per output: response error.
    pub error: Vec<String>,
    /// Per output: residual autocorrelation over the cross-correlation
    /// with the inputs, with the 99 % bands (the tests of `lifted
    /// validate`).
    pub residuals: Vec<String>,
    /// Step response.
    pub step: String,
    /// Bode magnitude over phase, with the empirical response of the
    /// data (Welch's estimate) as markers for a single-rate record.
    pub bode: String,
    /// Pole-zero map.
    pub pz: String,
    /// The order criterion's values per order (AIC, SVC, …, chosen order
    /// marked), when the route reports them.
    pub criterion: Option<String>,
}

/// The slots of [`Figures`], as the answer names them.
pub(super) const FIGURE_SLOTS: [&str; 8] = [
    "order",
    "response",
    "error",
    "residuals",
    "step",
    "bode",
    "pz",
    "criterion",
];

impl Figures {
    /// Each slot's content: its SVG documents (none for an absent figure).
    fn slot(&self, name: &str) -> Vec<&str> {
        fn one(s: &str) -> Vec<&str> {
            vec![s]
        }
        fn all(v: &[String]) -> Vec<&str> {
            v.iter().map(String::as_str).collect()
        }
        match name {
            "order" => self.order.iter().map(String::as_str).collect(),
            "response" => all(&self.response),
            "error" => all(&self.error),
            "residuals" => all(&self.residuals),
            "step" => one(&self.step),
            "bode" => one(&self.bode),
            "pz" => one(&self.pz),
            "criterion" => self.criterion.iter().map(String::as_str).collect(),
            _ => Vec::new(),
        }
    }

    /// Empties slot `name` (the page keeps what it shows there).
    fn clear(&mut self, name: &str) {
        match name {
            "order" => self.order = None,
            "response" => self.response.clear(),
            "error" => self.error.clear(),
            "residuals" => self.residuals.clear(),
            "step" => self.step.clear(),
            "bode" => self.bode.clear(),
            "pz" => self.pz.clear(),
            "criterion" => self.criterion = None,
            _ => {}
        }
    }

    /// The digest of every slot (a hash of its documents, with their
    /// count and lengths), and the figures without the slots whose digest
    /// is in `have` under the same slot, with those slots' names.
    pub fn unsent(
        mut self,
        have: &std::collections::BTreeMap<String, String>,
    ) -> (
        Figures,
        std::collections::BTreeMap<String, String>,
        Vec<String>,
    ) {
        use std::hash::{Hash, Hasher};
        let mut digests = std::collections::BTreeMap::new();
        let mut unchanged = Vec::new();
        for name in FIGURE_SLOTS {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            self.slot(name).hash(&mut h);
            let digest = format!("{:016x}", h.finish());
            if have.get(name) == Some(&digest) {
                self.clear(name);
                unchanged.push(name.to_string());
            }
            digests.insert(name.to_string(), digest);
        }
        (self, digests, unchanged)
    }
}

/// The answer to an identification.
#[derive(Debug, Clone, Serialize)]
pub struct Identified {
    /// The request's sequence number, as sent (the page drops an answer
    /// older than its latest request).
    pub seq: Option<u64>,
    /// Whether the model is stable (ρ(A) < 1).
    pub stable: bool,
    /// The spectral radius ρ(A) (`null` if not finite).
    pub spectral_radius: Option<f64>,
    /// The equivalent command line.
    pub command: String,
    /// Method name.
    pub method: String,
    /// Model order.
    pub order: usize,
    /// Order-selection data, when the route has it.
    pub order_selection: Option<OrderSelection>,
    /// Simulation fit per output.
    pub fits: Vec<Fit>,
    /// Poles as (re, im).
    pub poles: Vec<(f64, f64)>,
    /// The feedback test's verdict (`diagnostics.feedback`), in words,
    /// when it ran: "closed loop detected: …" or "no input depends on past
    /// output innovations …".
    pub feedback: Option<String>,
    /// The identification's warnings (`diagnostics.warnings`).
    pub warnings: Vec<String>,
    /// The figures (the slots in `unchanged` left empty).
    pub figures: Figures,
    /// Every figure slot's digest (the page sends them back as
    /// `Request::have`).
    pub figure_digests: std::collections::BTreeMap<String, String>,
    /// The slots not sent again: the page shows them already
    /// (`Request::have`).
    pub unchanged: Vec<String>,
    /// The subspace horizon the model was identified with (chosen by the
    /// held-out selection for order `auto`, else the request's), when the
    /// route has one: the page keeps it for the slider's numeric orders.
    pub horizon: Option<usize>,
    /// The (A, C) route of a subspace model (`shift` or `states`), chosen
    /// or requested, as `--estimator` spells it.
    pub estimator: Option<String>,
    /// The model's matrices.
    pub matrices: Matrices,
    /// The estimated parameters with their standard deviations (a
    /// polynomial model's polynomials, a process model's gains, time
    /// constants and dead times, a state-space model's entries), as
    /// `lifted identify` and `lifted analyze` print them; `None` without a
    /// covariance.
    pub parameters: Option<String>,
    /// The transfer function of each channel (empty, with a note in
    /// `transfer_note`, when the conversion fails).
    pub transfer_functions: Vec<ChannelTf>,
    /// Why there are no transfer functions, if so.
    pub transfer_note: Option<String>,
    /// The refinement's report (`--refine`), when there was one, with how
    /// it was judged (`judge`: `diagnostics.refinement_judge`).
    pub refinement: Option<serde_json::Value>,
    /// How the Kalman gain was made (`diagnostics.kalman_gain_route`), when
    /// it was checked on the records.
    pub gain: Option<lifted_subspace::GainCheck>,
    /// The record the fits and residuals are computed on.
    pub validation_data: String,
    /// Wall time of identify + validate + figures, milliseconds.
    pub elapsed_ms: f64,
}

/// One input-output pair's delay interval (`lifted delay --json`).
#[derive(Debug, Clone, Serialize)]
pub struct PairDelay {
    /// Input name.
    pub input: String,
    /// Output name.
    pub output: String,
    /// The input's hold m (base periods).
    pub hold: usize,
    /// The output's period n (base periods).
    pub period: usize,
    /// d_c ∈ [lower, upper) in base periods, when the pair gave one.
    pub interval: Option<[i64; 2]>,
    /// The same in seconds.
    pub interval_s: Option<[f64; 2]>,
    /// Why the pair gave none.
    pub failure: Option<String>,
}

/// The delays of the record's pairs.
#[derive(Debug, Clone, Serialize)]
pub struct Delays {
    /// Base period, seconds.
    pub base_period: f64,
    /// Lifted lags of the estimate.
    pub lags: usize,
    /// Significance in standard errors.
    pub sigmas: f64,
    /// One entry per input-output pair.
    pub pairs: Vec<PairDelay>,
}
