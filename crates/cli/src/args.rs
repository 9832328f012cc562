//! Command-line arguments (clap derive).
//!
//! Long file: the command-line arguments of every command (clap derive),
//! one struct per command with the help text of each flag; kept in one file
//! so that the flags' names and defaults read as one reference.

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Identify and control multirate sampled-data systems: excitation design,
/// identification (q-Markov Cover, subspace, multirate), validation, reports
/// and paper reproductions.
#[derive(Debug, Parser)]
#[command(name = "lifted", version, propagate_version = true)]
pub struct Cli {
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The memory budget of the commands that size their work by options.
#[derive(Debug, Args, Clone, Default)]
pub struct ResourceArgs {
    /// Memory budget of one request, in bytes or with a suffix (`4G`, `512M`, `1.5GiB`,
    /// `2GB`): K/M/G/T and KiB/MiB/GiB/TiB are powers of 1024, kB/MB/GB/TB powers of 1000.
    /// Overrides the environment variable LIFTED_MEMORY_LIMIT (default: half the physical
    /// memory). An option whose matrices would need more is an error (exit 2) before anything
    /// is allocated.
    #[arg(long, value_parser = parse_memory_limit)]
    pub memory_limit: Option<u64>,
}

/// `--refine-check`: `tests:C`, `t:C` or `margin:P` (`lifted_pem::CheckRule`'s
/// `FromStr`).
fn parse_refine_check(s: &str) -> Result<lifted_pem::CheckRule, String> {
    s.parse().map_err(|e: lifted_pem::Error| e.to_string())
}

/// `--memory-limit`: bytes with an optional binary (K, M, G, T, KiB…TiB) or
/// decimal (kB, MB, GB, TB) suffix; positive, at most 2^64 − 1 bytes.
pub fn parse_memory_limit(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, suffix) = t.split_at(split);
    let unit: f64 = match suffix.trim() {
        "" | "B" | "b" => 1.0,
        "K" | "k" | "KiB" => 1024.0,
        "M" | "m" | "MiB" => 1024f64.powi(2),
        "G" | "g" | "GiB" => 1024f64.powi(3),
        "T" | "t" | "TiB" => 1024f64.powi(4),
        "kB" | "KB" => 1e3,
        "MB" => 1e6,
        "GB" => 1e9,
        "TB" => 1e12,
        other => {
            return Err(format!(
                "unknown unit '{other}' (use bytes, K/M/G/T, KiB…TiB or kB/MB/GB/TB)"
            ));
        }
    };
    let value: f64 = number
        .parse()
        .map_err(|_| format!("'{text}' is not a size such as 4G or 512M"))?;
    let bytes = (value * unit).round();
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("'{text}' is not a positive size below 2^64 bytes"));
    }
    Ok(bytes as u64)
}

/// The commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Generate an inverse PRBS (Zhu 2000 eq. II-4), held n_r samples, and write it as CSV.
    Prbs(PrbsArgs),
    /// Generate a seeded random binary sequence (±a, held n_r samples).
    Rbs(RbsArgs),
    /// Generate generalized binary noise (switching probability p).
    Gbn(GbnArgs),
    /// Generate seeded Gaussian white noise (standard deviation σ, held n_r samples).
    Gaussian(GaussianArgs),
    /// Generate a Schroeder-phased multisine.
    Multisine(MultisineArgs),
    /// Propose (n, n_r, a) from the plant's time scales and the actuator rate (Zhu 2000 §III.D, Table II).
    Design(DesignArgs),
    /// Simulate a model on an input CSV (optional slow output sampling and noise) and write a data CSV.
    Simulate(SimulateArgs),
    /// Identify a discrete state-space model from CSV data and write a model file.
    Identify(IdentifyArgs),
    /// Validate a model on data: fit %, residual whiteness, input-residual cross-correlation.
    Validate(ValidateArgs),
    /// Convert a model: transfer function, state space, continuous (d2c) or discrete (c2d).
    Convert(ConvertArgs),
    /// Bode magnitude and phase of a model, as CSV or SVG.
    Bode(BodeArgs),
    /// Step response of a model, as CSV or SVG.
    Step(StepArgs),
    /// Estimate the time delay of every input-output pair from multirate data (thesis §4.4).
    Delay(DelayArgs),
    /// Recover the plant from identified closed-loop models (Ren & Zhu 2009 eqs. 10–12).
    Closedloop(ClosedloopArgs),
    /// Design DMC / state-space MPC (optionally dual-rate inferential) from a model file and simulate the loop (thesis ch. 8).
    Mpc(MpcArgs),
    /// Stability-robustness measures β_sr, β_dr and the monodromy spectral radius of a dual-rate loop (thesis ch. 9).
    Robust(RobustArgs),
    /// Poles, zeros, DC gain, stability, H2 and H∞ norms (with the peak frequency) and Hankel singular values of a model.
    Analyze(AnalyzeArgs),
    /// Discrete LQR: the stabilising DARE solution, the gain K of u = −Kx and the closed-loop poles.
    Lqr(LqrArgs),
    /// One self-contained HTML page: excitation, fit, order selection, step, Bode, poles/zeros, validation.
    Report(ReportArgs),
    /// Run the reproductions of the papers' experiments and report every acceptance check.
    Reproduce(ReproduceArgs),
    /// The interactive identification page (Zhu 2000 §III.D) on a local web server.
    Studio(StudioArgs),
}

/// `lifted studio`.
#[derive(Debug, Args)]
pub struct StudioArgs {
    /// A data CSV to open at start (otherwise load one in the page).
    #[arg(long)]
    pub data: Option<String>,
    /// TCP port on 127.0.0.1 (0: any free port; the URL is printed).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Memory budget of one request (an identification's record and matrices); uploads
    /// are checked cell by cell without keeping their values.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// Output file and signal name shared by the generators.
#[derive(Debug, Args)]
pub struct SignalOut {
    /// Output CSV file (columns `t,<name>`, or `t` and one column per channel).
    #[arg(long)]
    pub out: String,
    /// Column name of the signal; comma separated for several channels (one column each).
    #[arg(long, visible_alias = "inputs", default_value = "u1")]
    pub name: String,
    /// Number of mutually uncorrelated channels (default: one per `--name`). With one name,
    /// its trailing digits are dropped and the channels are numbered (u1 → u1, u2, …).
    #[arg(long)]
    pub channels: Option<usize>,
    /// Sample period T written in the time column (seconds).
    #[arg(long, default_value_t = 1.0)]
    pub ts: f64,
}

/// `lifted prbs`.
#[derive(Debug, Args)]
pub struct PrbsArgs {
    /// m-sequence order n (period m = 2^n − 1), 2..=32.
    #[arg(long)]
    pub order: u32,
    /// Magnitude a (the signal is ±a).
    #[arg(long)]
    pub amplitude: f64,
    /// Hold n_r: each PRBS value lasts n_r samples (eq. II-7).
    #[arg(long, default_value_t = 1)]
    pub hold: usize,
    /// Number of periods (an inverse PRBS period is 2 n_r m samples, a plain one n_r m).
    #[arg(long, default_value_t = 1)]
    pub periods: usize,
    /// Inverse PRBS (period 2m, u(k+m) = −u(k), Zhu 2000 eq. II-4); default is the plain ±a m-sequence.
    #[arg(long)]
    pub inverse: bool,
    /// Start phase of the sequence (advances the register); the PRBS itself is deterministic.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output file, name, period.
    #[command(flatten)]
    pub out: SignalOut,
}

/// `lifted rbs`.
#[derive(Debug, Args)]
pub struct RbsArgs {
    /// Number of samples.
    #[arg(long)]
    pub len: usize,
    /// Magnitude a.
    #[arg(long, default_value_t = 1.0)]
    pub amplitude: f64,
    /// Hold n_r (samples per value).
    #[arg(long, default_value_t = 1)]
    pub hold: usize,
    /// Seed of the ChaCha8 generator.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output file, name, period.
    #[command(flatten)]
    pub out: SignalOut,
}

/// `lifted gaussian`.
#[derive(Debug, Args)]
pub struct GaussianArgs {
    /// Number of samples.
    #[arg(long)]
    pub len: usize,
    /// Standard deviation σ.
    #[arg(long, default_value_t = 1.0)]
    pub std: f64,
    /// Hold n_r (samples per value).
    #[arg(long, default_value_t = 1)]
    pub hold: usize,
    /// Seed of the ChaCha8 generator.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output file, name, period.
    #[command(flatten)]
    pub out: SignalOut,
}

/// `lifted gbn`.
#[derive(Debug, Args)]
pub struct GbnArgs {
    /// Number of samples.
    #[arg(long)]
    pub len: usize,
    /// Magnitude a.
    #[arg(long, default_value_t = 1.0)]
    pub amplitude: f64,
    /// Switching probability per (held) step, in (0, 1].
    #[arg(long, default_value_t = 0.5)]
    pub switch_probability: f64,
    /// Hold n_r (samples per step).
    #[arg(long, default_value_t = 1)]
    pub hold: usize,
    /// Seed of the ChaCha8 generator.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output file, name, period.
    #[command(flatten)]
    pub out: SignalOut,
}

/// `lifted multisine`.
#[derive(Debug, Args)]
pub struct MultisineArgs {
    /// Number of samples.
    #[arg(long)]
    pub len: usize,
    /// RMS value.
    #[arg(long, default_value_t = 1.0)]
    pub amplitude: f64,
    /// Period P in samples.
    #[arg(long, default_value_t = 1024)]
    pub period: usize,
    /// First excited harmonic.
    #[arg(long, default_value_t = 1)]
    pub first_harmonic: usize,
    /// Last excited harmonic (default ⌈P/2⌉ − 1).
    #[arg(long)]
    pub last_harmonic: Option<usize>,
    /// Output file, name, period.
    #[command(flatten)]
    pub out: SignalOut,
}

/// `lifted design`.
#[derive(Debug, Args)]
pub struct DesignArgs {
    /// Output sample period T in seconds (Table II: 0.01).
    #[arg(long, default_value_t = 0.01)]
    pub ts: f64,
    /// Fastest rate (Hz) at which the actuator executes a new command (Table II: 30).
    #[arg(long, default_value_t = 30.0)]
    pub actuator_rate: f64,
    /// Actuator margin: T_p ≥ margin / rate (Table II: 3).
    #[arg(long, default_value_t = 3.0)]
    pub actuator_margin: f64,
    /// Slowest mode to excite, Hz (Table II: 0.025).
    #[arg(long, default_value_t = 0.025)]
    pub slowest_mode: f64,
    /// PRBS magnitude allowed by the process.
    #[arg(long, default_value_t = 1.0)]
    pub amplitude: f64,
    /// Smallest PRBS order to propose.
    #[arg(long, default_value_t = 2)]
    pub min_order: u32,
    /// Also write the proposal as JSON.
    #[arg(long)]
    pub json: Option<String>,
}

/// `lifted simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Model file (JSON); a continuous model is discretised by ZOH at --ts.
    #[arg(long)]
    pub model: String,
    /// Input CSV (header row; the input columns are read by name), or a .npy array (see --columns).
    #[arg(long)]
    pub input: String,
    /// Names of the columns of a .npy input file, in order, comma separated (default c0, c1, …);
    /// a column named t or time is the time column. Ignored for a CSV input.
    #[arg(long)]
    pub columns: Option<String>,
    /// Input column names, comma separated (default: the model's input names, else u1,u2,…).
    /// In closed loop (--controller) they are the excitation r₂ added at the plant input,
    /// and optional: without --inputs there is none.
    #[arg(long)]
    pub inputs: Option<String>,
    /// Base period T (default: the model's, else the input file's time column).
    #[arg(long)]
    pub ts: Option<f64>,
    /// Slow output sampling, NAME=PERIOD (base periods), repeatable or comma separated.
    #[arg(long = "output-period")]
    pub output_period: Vec<String>,
    /// Input hold, NAME=SAMPLES (the input changes only every m base periods), repeatable or comma separated.
    #[arg(long = "hold")]
    pub hold: Vec<String>,
    /// Output noise at this signal-to-noise ratio (variance ratio); none by default.
    #[arg(long)]
    pub snr: Option<f64>,
    /// Noise model file (n_y outputs; continuous or discrete at T): coloured noise H(q)e instead of white.
    #[arg(long)]
    pub noise_model: Option<String>,
    /// Measure the SNR on every fast sample or only on each output's measured samples.
    #[arg(long, value_enum, default_value_t = SnrSamplesArg::Fast)]
    pub snr_samples: SnrSamplesArg,
    /// Noise seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Closed loop: discrete controller model file (n_u outputs, n_y inputs; at T, or at m·T to run every m samples).
    #[arg(long)]
    pub controller: Option<String>,
    /// Closed loop: set-point columns r₁ of the input CSV, one per output, comma separated (default: zero set-points).
    #[arg(long)]
    pub references: Option<String>,
    /// Closed loop: what the controller sees between slow samples.
    #[arg(long, value_enum, default_value_t = FeedbackArg::Fast)]
    pub feedback: FeedbackArg,
    /// Output data CSV.
    #[arg(long)]
    pub out: String,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// Samples the SNR is measured on (`--snr-samples`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SnrSamplesArg {
    /// Every fast sample (default).
    Fast,
    /// Each output's measured samples only.
    Measured,
}

/// Feedback between slow samples (`--feedback`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FeedbackArg {
    /// The output at every base period (default).
    Fast,
    /// The last measured sample, held until the next one.
    HoldLast,
}

/// Order-selection rules (`--order-criterion`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CriterionArg {
    /// Simulation fit on held-out data (each of six blocks held out once for records up to
    /// 2e4 samples, else the last third of the record), with the horizon and
    /// the (A, C) route chosen the same way when they are not given (single-rate N4SID, MOESP,
    /// CVA; default); on refined records of up to 2e4 samples the best three orders are then
    /// compared by the held-out fit of the model each delivers (refinement included). Records
    /// too short for any held-out block at the horizon get the order by AICc on the
    /// output-error fits of the whole record. Multirate N4SID/MOESP/CVA records of up to 2e5
    /// samples: every order identified on the first two thirds and simulated on the last third,
    /// then the smallest orders near the best (and the best) judged by their models refined on
    /// the first two thirds (unless --refine none), with the orders whose start is unstable
    /// there refined from their stabilised start (they lead only with a positive held-out fit
    /// and a stable start on the whole record). PBSID and SSARX: the order by the same
    /// held-out fit at the past horizon of the whole record; single-rate IV at its alpha;
    /// multirate IV as the multirate subspace methods. q-Markov uses the singular-value gap.
    Validation,
    /// Largest gap ln(σ_n/σ_{n+1}) of the singular values.
    Gap,
    /// Bauer's singular value criterion on the canonical correlations.
    Svc,
    /// Akaike's information criterion on the simulation error.
    Aic,
    /// Small-sample corrected AIC.
    Aicc,
    /// Bayesian (Schwarz) information criterion.
    Bic,
}

/// Route from the subspace to (A, C) (`--estimator`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EstimatorArg {
    /// Chosen by the held-out simulation fit (single-rate N4SID, MOESP, CVA on records up to
    /// 2e5 samples; default); shift invariance elsewhere.
    Auto,
    /// Shift invariance of the extended observability matrix (consistent).
    Shift,
    /// Least squares on the estimated state sequences (the thesis' N4SID route; biased for short horizons).
    States,
}

/// Route of (B, D, x₀) after (A, C) (`--bd`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BdArg {
    /// Output-error least squares on the data; the projection only when A is too unstable
    /// for the regression over the record (default).
    Auto,
    /// Output-error least squares on the data, always.
    OutputError,
    /// The projection on the compressed data (one pass over a file).
    Projection,
}

/// Refinement after the identification (`--refine`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RefineArg {
    /// The prediction-error refinement where it pays (default): when its predicted work is at
    /// most 4e9 operations (about 1 s; 8e9 for the joint iterations of multirate records) or the
    /// record has fewer than 10 000 samples, and the estimate is stable (a record with too few
    /// measured samples for its parameters keeps the identified model);
    /// `diagnostics.refinement_decision` says what was decided and why.
    Auto,
    /// No refinement.
    None,
    /// Prediction-error method: one-step prediction error, Kalman gain estimated.
    Pem,
    /// Output-error method: simulation error.
    Oe,
}

/// Offset handling (`--detrend`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DetrendArg {
    /// identify: as `mean`; validate/report: apply the model file's operating point, or remove the record's means if it has none.
    Auto,
    /// Use the data as they are.
    None,
    /// Remove each channel's mean (over its sampled values).
    Mean,
    /// Remove a least-squares straight line from each channel.
    Linear,
}

/// Identification methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Weighted multirate q-Markov Cover (Zhu 2000): one inverse-PRBS data file per input.
    Qmarkov,
    /// N4SID (subspace, W1 = W2 = I).
    N4sid,
    /// MOESP (subspace).
    Moesp,
    /// CVA (subspace, canonical correlations).
    Cva,
    /// Instrumental-variable subspace (thesis ch. 7), open or closed loop.
    Iv,
    /// Predictor-based subspace (PBSID-opt, Chiuso 2007): closed-loop data without an
    /// instrument; --horizon sets the past horizon p (default: Akaike's choice up to 30,
    /// shortened with a note where the past outputs are linearly dependent given the
    /// past inputs), the future horizon is min(p, 10).
    Pbsid,
    /// SSARX (Jansson 2003), the predictor-based method with a canonical-correlation
    /// step: closed-loop data without an instrument; horizons as pbsid.
    Ssarx,
    /// Row-wise PBSID (Chiuso & Picci 2005), the predictor-based method that regresses the
    /// future outputs one block row at a time: closed-loop data without an instrument;
    /// horizons as pbsid.
    #[value(name = "pbsid-rowwise")]
    PbsidRowwise,
    /// ARX, A(q) y = B(q) u + e, by least squares, with the parameters' standard deviations:
    /// --orders "na nb nk" (the same for every input–output pair; A full for several outputs),
    /// else the structure scan (na, nb up to --max-order, nk 1–5) by --order-criterion
    /// (validation: the one-step loss on the last third of the records; aic; bic = MDL).
    /// Single-rate records (its regressors are past outputs).
    Arx,
    /// FIR, y = B(q) u + e (ARX with na = 0): --orders "nb nk", else the scan over nb.
    Fir,
    /// Output error, y = B(q)/F(q) u + e, by prediction-error minimisation of the simulation
    /// error on the measured samples (multirate records too), with the parameters' standard
    /// deviations: --orders "nb nf nk", or --order n (nb = nf = n, the delay estimated).
    Oe,
    /// ARMAX, A(q) y = B(q) u + C(q) e, by prediction-error minimisation (consistent in closed
    /// loop, the direct method): --orders "na nb nc nk", or --order n. On multirate records
    /// the predictor skips the unmeasured samples (with --a-structure full, one Kalman
    /// predictor for all outputs).
    Armax,
    /// Box–Jenkins, y = B/F u + C/D e, by prediction-error minimisation (consistent in closed
    /// loop): --orders "nb nc nd nf nk", or --order n. Multirate records too (the predictor
    /// skips the unmeasured samples).
    Bj,
    /// Process model per input–output pair (MATLAB's procest): gain, time constants and dead
    /// time of --process (default p1d, first order plus dead time), by output error on the
    /// measured samples (multirate records too); the inputs are taken relative to their first
    /// sample (the plant at rest before the test), an output offset is estimated.
    Process,
    /// Regularised FIR (impulse response, MATLAB's impulseest): --orders "lags nk" (default
    /// "70 1"), --kernel tc|dc, hyperparameters by the marginal likelihood. Single-rate records.
    Impulse,
}

/// Kernels of the regularised FIR and ARX (`--kernel`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum KernelArg {
    /// Tuned/correlated: c λ^max(i,j).
    Tc,
    /// Diagonal/correlated: c ρ^|i−j| λ^((i+j)/2).
    Dc,
}

/// The pattern of a MIMO ARX's A (`--a-structure`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AStructureArg {
    /// Every output's past in every output's equation.
    Full,
    /// Each output's own past only (one MISO model per output).
    Diagonal,
}

/// The denominators of an OE or BJ model (`--f-structure`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FStructureArg {
    /// One F per input–output pair (MATLAB's oe).
    PerInput,
    /// One F per output shared by its inputs' terms (SIPPY's OE).
    Common,
}

/// How the inputs move between samples (`--intersample`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InterSampleArg {
    /// Zero-order hold: each sample held until the next.
    Zoh,
    /// First-order hold: linear from each sample to the next.
    Foh,
}

/// Process-model structures (`--process`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ProcessArg {
    /// K e^(−θs)/(1 + T1 s).
    P1d,
    /// K e^(−θs)/((1 + T1 s)(1 + T2 s)).
    P2d,
    /// K e^(−θs)/(s(1 + T1 s)) (integrating).
    P1di,
    /// K (1 + Tz s) e^(−θs)/((1 + T1 s)(1 + T2 s)).
    P2dz,
    /// K e^(−θs)/(1 + 2ζ Tw s + Tw² s²) (underdamped allowed).
    P2du,
}

impl MethodArg {
    /// Lower-case name written in the model file.
    pub fn name(self) -> &'static str {
        match self {
            MethodArg::Qmarkov => "qmarkov",
            MethodArg::N4sid => "n4sid",
            MethodArg::Moesp => "moesp",
            MethodArg::Cva => "cva",
            MethodArg::Iv => "iv",
            MethodArg::Pbsid => "pbsid",
            MethodArg::Ssarx => "ssarx",
            MethodArg::PbsidRowwise => "pbsid_rowwise",
            MethodArg::Arx => "arx",
            MethodArg::Fir => "fir",
            MethodArg::Oe => "oe",
            MethodArg::Armax => "armax",
            MethodArg::Bj => "bj",
            MethodArg::Process => "process",
            MethodArg::Impulse => "impulse",
        }
    }
}

/// Columns and layout of a data file.
#[derive(Debug, Args, Clone)]
pub struct DataArgs {
    /// Input column names, comma separated (default for validate/report: the model's input names).
    #[arg(long)]
    pub inputs: Option<String>,
    /// Output column names, comma separated (default for validate/report: the model's output names).
    #[arg(long)]
    pub outputs: Option<String>,
    /// Base period T in seconds (default: from the time column `t`).
    #[arg(long)]
    pub ts: Option<f64>,
    /// Declared output sampling period, NAME=PERIOD in base periods (repeatable); otherwise inferred from the empty cells.
    #[arg(long = "output-period")]
    pub output_period: Vec<String>,
    /// Names of the columns of a .npy data file, in order, comma separated (default c0, c1, …);
    /// a column named t or time is the time column. Ignored for CSV files (their header row
    /// names the columns).
    #[arg(long)]
    pub columns: Option<String>,
}

/// `lifted identify`.
#[derive(Debug, Args, Clone)]
pub struct IdentifyArgs {
    /// Identification method (default n4sid, as the workflow's and the Python package's
    /// default).
    #[arg(long, value_enum, default_value = "n4sid")]
    pub method: MethodArg,
    /// Data file, CSV or .npy (see --columns); repeat for several experiments (q-Markov: one file per input channel, in input order). A `*` or `?` in the file name is expanded to the matching files in name order (quote it: `--data 'hist-*.npy'`).
    #[arg(long, required = true)]
    pub data: Vec<String>,
    /// The --data files are consecutive shards of one record, in the order given (a pattern's
    /// files in name order), not separate experiments. N4SID/MOESP/CVA stream them in two passes
    /// on the machine's threads when they are too large for the held-out structure selection.
    #[arg(long)]
    pub concat: bool,
    /// Columns and layout.
    #[command(flatten)]
    pub columns: DataArgs,
    /// Model order n, or `auto`: chosen from the data by the rule of --order-criterion (default:
    /// simulation fit on held-out blocks).
    #[arg(long, default_value = "auto")]
    pub order: String,
    /// Polynomial models: MATLAB's order vector, "na nb nk" (arx), "nb nk" (fir), "nb nf nk"
    /// (oe), "na nb nc nk" (armax) or "nb nc nd nf nk" (bj), the same for every input–output pair
    /// (spaces or commas). Default (arx, fir): chosen by the structure scan.
    #[arg(long)]
    pub orders: Option<String>,
    /// Process models (--method process): the structure.
    #[arg(long, value_enum)]
    pub process: Option<ProcessArg>,
    /// Process models: a parameter held at a value instead of estimated, as NAME=VALUE in the
    /// data's units (repeatable): a parameter of the structure for every input (Td=7.3: a dead
    /// time known from the plant; K, Tp1, Tp2, Tz, Tw, Zeta), one input's (Td(u1)=7.3), or
    /// offset. A held parameter keeps its value and has no variance.
    #[arg(long, value_name = "NAME=VALUE")]
    pub process_fix: Vec<String>,
    /// Process models: how the inputs move between their samples: zoh (held, the default: a
    /// controller's output) or foh (linear from sample to sample: a sampled continuous signal;
    /// MATLAB's InterSample).
    #[arg(long, value_enum)]
    pub intersample: Option<InterSampleArg>,
    /// Regularised FIR (--method impulse): the prior's kernel (default tc). With --method arx
    /// and --orders (or --order): the regularised ARX (MATLAB's arxRegul), one kernel for the past
    /// outputs' and one for the inputs' coefficients, hyperparameters by the marginal likelihood.
    #[arg(long, value_enum)]
    pub kernel: Option<KernelArg>,
    /// ARX and ARMAX of several outputs: the pattern of A: full (every output's past in every
    /// output's equation: MATLAB's arx/armax with a full na matrix; ARX's default) or diagonal
    /// (each output's own past only: one MISO model per output, SIPPY's and sysidentpy's;
    /// na = n·eye(ny); ARMAX's default).
    #[arg(long, value_enum)]
    pub a_structure: Option<AStructureArg>,
    /// OE and BJ: the denominators: per-input (one F per input–output pair, MATLAB's oe and bj;
    /// the default) or common (one F per output shared by its inputs' terms, y = (B1 u1 + … +
    /// Bm um)/F + noise: SIPPY's OE and BJ, fewer parameters where the inputs see the same
    /// modes). Multirate records too.
    #[arg(long, value_enum)]
    pub f_structure: Option<FStructureArg>,
    /// Largest order considered by `auto` (single-rate N4SID/MOESP/CVA: lowered, with a warning,
    /// to the largest order the records and horizon identify).
    #[arg(long, default_value_t = 10)]
    pub max_order: usize,
    /// Rule of `--order auto` (subspace and single-rate IV methods): the
    /// simulation fit on held-out data (default), the largest singular-value
    /// gap, Bauer's SVC, or AIC / AICc / BIC on the simulation error (SIPPY's
    /// definitions). The values per order are written to the diagnostics
    /// either way.
    #[arg(long, value_enum, default_value_t = CriterionArg::Validation)]
    pub order_criterion: CriterionArg,
    /// Horizon i: past = future block rows (subspace: by default chosen with the order by the
    /// held-out simulation fit among 5, 10, 15, 20, 30 for records up to 2e5 samples, fewer
    /// beyond (10 alone from 1e6), data files up to 16 MiB; streamed files 10; a record too
    /// short for held-out blocks and for horizon 10
    /// gets the horizon with the smallest AICc among those it supports), α (IV, default 8, or the longest a record too short for 8 supports, with a warning).
    #[arg(long)]
    pub horizon: Option<usize>,
    /// PBSID/SSARX: future horizon f (default min(p, 10) with the past horizon p = --horizon,
    /// 10 when the past horizon is Akaike's choice, or the longest a record too short for 10
    /// supports, with a warning).
    #[arg(long)]
    pub future: Option<usize>,
    /// Estimate a direct feedthrough D (`--feedthrough`, or `--feedthrough true`) or fix D = 0
    /// (`--feedthrough false`: a strictly proper model, as `mpc` takes). Default: single-rate
    /// N4SID, MOESP and CVA keep D only where the records support it (D free against D = 0 by
    /// the Bayesian information criterion on the simulation errors; streamed files over 2e5
    /// samples: estimated);
    /// PBSID/SSARX, IV and multirate records fix D = 0 (in closed loop an estimated D is biased
    /// when the controller reacts within the sample). Not used with qmarkov.
    #[arg(long, num_args = 0..=1, default_missing_value = "true", value_name = "BOOL")]
    pub feedthrough: Option<bool>,
    /// IV: past instrument block rows α_p (default 2α).
    #[arg(long)]
    pub instrument_past: Option<usize>,
    /// q-Markov: number q of Markov/covariance parameters matched (default 60, capped below n_r m).
    #[arg(long)]
    pub q: Option<usize>,
    /// Input hold n_r in base periods (q-Markov: the PRBS hold; multirate: the input hold).
    #[arg(long, default_value_t = 1)]
    pub hold: usize,
    /// q-Markov: PRBS order n of the excitation.
    #[arg(long)]
    pub prbs_order: Option<u32>,
    /// q-Markov: PRBS magnitude a, one value for every input or one per input (default: read
    /// from the data).
    #[arg(long, value_delimiter = ',')]
    pub amplitude: Vec<f64>,
    /// q-Markov: diagonal output weighting Q of eq. (III-6), one positive value for every
    /// output or one per output (default: the identity).
    #[arg(long, value_delimiter = ',')]
    pub output_weight: Vec<f64>,
    /// IV: instrument column names (one per input; the external excitation in closed loop).
    #[arg(long)]
    pub instrument: Option<String>,
    /// Subspace methods: (A, C) by shift invariance (consistent, default) or from the state sequences.
    #[arg(long, value_enum, default_value_t = EstimatorArg::Auto)]
    pub estimator: EstimatorArg,
    /// Subspace methods: (B, D, x₀) by output-error least squares on the data (`auto`, the
    /// default: a data file is read a second time, memory stays flat) or by the projection on
    /// the compressed data (`projection`: one pass, less accurate on real records).
    #[arg(long, value_enum, default_value_t = BdArg::Auto)]
    pub bd: BdArg,
    /// Offsets removed before identification (per channel, from the estimation record); the
    /// means are stored in the model file as its operating point and re-applied by simulate,
    /// validate and report. `linear` also removes trends (in memory, not streamed).
    #[arg(long, value_enum, default_value_t = DetrendArg::Mean)]
    pub detrend: DetrendArg,
    /// Refine the identified model by Levenberg–Marquardt on the prediction error (`pem`) or
    /// the simulation error (`oe`); multirate records use their measured samples only. The
    /// refined model is kept only if its simulation fit is at least as good: on six held-out
    /// blocks when they tell the two apart (`--refine-check`; single-rate N4SID/MOESP/CVA records
    /// of up to 2e4 samples; when they do not, the subspace model stays), else on the record, and
    /// never when it simulates the record worse than its start; `diagnostics.refinement_judge`
    /// says which.
    /// Default `auto`: the prediction error where it pays (see `auto`), `none` to skip it.
    #[arg(long, value_enum, default_value_t = RefineArg::Auto)]
    pub refine: RefineArg,
    /// Largest number of refinement iterations.
    #[arg(long, default_value_t = 100)]
    pub refine_iterations: usize,
    /// Bound on the refinement's work in floating-point operations (iterations × the cost of
    /// one; ≈ 4e9 per second per core). Large records reach it before convergence: the model
    /// then carries a warning; raise it to let the iterations finish.
    #[arg(long, default_value_t = 2e10)]
    pub refine_max_work: f64,
    /// How the six held-out blocks tell the refinement and the subspace model apart:
    /// `tests:C` (the default, `tests:0.95`: a paired t-test or a sign test of the per-block
    /// differences rejects "no difference" at two-sided confidence C), `t:C` (the t-test
    /// alone) or `margin:P` (mean held-out fits more than P points apart; `margin:3` was the
    /// default before, chosen on a benchmark's validation halves); either way the median block
    /// must agree. Recorded in `diagnostics.refinement_judge.rule`.
    #[arg(long, value_parser = parse_refine_check, default_value = "tests:0.95")]
    pub refine_check: lifted_pem::CheckRule,
    /// Largest number of iterations of each held-out block's refinement in that judgement and
    /// in the refined shortlist of an automatic order (default 20, the iteration limit of
    /// MATLAB's `ssest`; the delivered model's refinement keeps --refine-iterations). Recorded
    /// in `diagnostics.refinement_judge.fold_iterations`.
    #[arg(long, default_value_t = lifted_workflow::JUDGE_ITERATIONS)]
    pub judge_iterations: usize,
    /// The Kalman-gain check (single-rate subspace and IV models) stops its iterations over K
    /// when one lowers the one-step cost by less than this share of the cost's sampling spread
    /// √(2/N) (default 0.01; 0: run to 30 iterations or a decrease below 1e-9; recorded in
    /// the model's diagnostics, `kalman_gain_route.stop`).
    #[arg(long, default_value_t = 0.01)]
    pub gain_stop_share: f64,
    /// The Kalman-gain check minimises first on the covariances of its start's one-step errors
    /// (BFGS, no pass over the records per step), then finishes on the records (default true);
    /// false: Levenberg–Marquardt on the records alone. Recorded in
    /// `kalman_gain_route.covariance_iterations`.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub gain_covariance_start: bool,
    /// Automatic order: most models identified to find a stable one (the rule's choice, then
    /// the next orders of its ranking; default 6; 1: no retry). The selection's rules are
    /// recorded in `diagnostics.selection_policy`.
    #[arg(long, default_value_t = 6)]
    pub stable_tries: usize,
    /// Automatic order: orders compared by the refined shortlist (each scored by the model it
    /// delivers after the refinement; default 3).
    #[arg(long, default_value_t = 3)]
    pub shortlist: usize,
    /// Multirate records, automatic order: orders within this many points of the best held-out
    /// fit enter the refined shortlist (default 5).
    #[arg(long, default_value_t = 5.0, allow_hyphen_values = true)]
    pub shortlist_span: f64,
    /// Automatic order and horizon: the smallest within this many points of the best held-out
    /// fit is kept (parsimony; default 0.5).
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true)]
    pub selection_tolerance: f64,
    /// The score (percent) of a held-out block whose model failed, and the floor of every
    /// block's fit in the means (default -100).
    #[arg(long, default_value_t = -100.0, allow_hyphen_values = true)]
    pub failed_fold: f64,
    /// A work or record-length budget of the default route, as NAME=VALUE (repeatable):
    /// auto_refine_work (default 4e9 operations), auto_refine_work_joint (8e9),
    /// auto_refine_samples (10000), refine_check_samples (20000), refine_check_work (4e9),
    /// gain_check_samples (200000), covariance_work (4e9), gain_check_varx_work (4e9),
    /// gain_check_minimise_work (8e9).
    /// refine_check_samples also bounds the held-out check of a multirate route's model against
    /// the single-rate model of the record with its slow outputs interpolated (the route's model
    /// is kept only when six held-out blocks favour it; `diagnostics.multirate_check`).
    /// Above a budget the stage is skipped or judged more cheaply, and the diagnostics say so;
    /// the values used are recorded in `diagnostics.budgets`.
    #[arg(long, value_name = "NAME=VALUE")]
    pub budget: Vec<String>,
    /// Offer a stable model instead of an unstable one: when the estimated A (lifted Ā for
    /// multirate records, the cover's Â for q-Markov) has an eigenvalue on or outside the unit
    /// circle it is re-estimated by the zero-padded shift A = Γ⁺[Γ↓; 0] (Maciejowski's
    /// stabilised shift invariance, eigenvalues inside the circle), B, D are fitted to it, and
    /// the model is then refined by the prediction-error method (or the `--refine` cost) with
    /// every iterate stable, which brings it back to the data; `diagnostics.stable_route` says
    /// what was done. An estimate whose poles are only marginal (integrators: ρ(A) < 1 + δ,
    /// `--integrator-tolerance`) is not re-estimated: those poles are moved just inside, to
    /// radius 1 − δ (a stable model cannot hold an integrator; a warning says so), and the
    /// polish follows. A model still unstable is an error naming its spectral radius.
    #[arg(long)]
    pub stable: bool,
    /// Do not estimate the covariance of a state-space model's entries (by default the model
    /// file carries it: one pass of the prediction-error Jacobian at the model, within
    /// `--budget covariance_work`, 4e9 operations; `lifted bode`, `step` and `report` draw its
    /// confidence bands; `diagnostics.covariance` says what it rests on). Polynomial and
    /// process models carry their own covariance either way.
    #[arg(long)]
    pub no_covariance: bool,
    /// Integrator tolerance δ: poles with |λ| < 1 + δ are integrators (on the unit circle,
    /// estimated just outside it), not instability: `--refine pem` starts from them instead of
    /// the zero-padded shift and may keep them, `--stable` moves them just inside (radius
    /// 1 − δ; a stable model cannot hold an integrator) and says so;
    /// `diagnostics.integrators` lists the poles within δ of the circle. In [0, 1); 0 treats
    /// every ρ(A) ≥ 1 as unstable. Default 2/N for the longest record of N samples (a unit
    /// root is estimated within O(1/N) of 1, Dickey–Fuller; ρ ≤ 1 + 2/N grows by at most e²
    /// over the record).
    #[arg(long)]
    pub integrator_tolerance: Option<f64>,
    /// Take the identification options from a plan instead of the option flags: a model file
    /// written by `lifted identify` (its `diagnostics.options`, the options that made it) or a
    /// JSON object of the workflow options (as `--write-plan` writes it; fields left out take
    /// their defaults, an unknown field is an error). The data flags (--data, --concat,
    /// --columns, --inputs, --outputs, --instrument, --ts, --output-period) still select the
    /// records, and the other option flags must be left at their defaults. The same records
    /// then give the same model, bit for bit.
    #[arg(long, value_name = "FILE")]
    pub plan: Option<String>,
    /// Write the options of this run (its plan: every option with the value used, defaults
    /// included) to this JSON file, for `--plan`.
    #[arg(long, value_name = "FILE")]
    pub write_plan: Option<String>,
    /// Output model file (JSON).
    #[arg(long)]
    pub out: String,
    /// Print the wall time of each phase (read, compress, SVD, estimate; the
    /// structure selection and the whole subspace step with it, the streamed
    /// route's second pass, the multirate route with its order selection,
    /// its second start and its check against interpolation, the
    /// Kalman-gain check and the refinement when they ran).
    #[arg(long)]
    pub profile: bool,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

impl IdentifyArgs {
    /// The arguments at the command's defaults (its parser's, from a
    /// command line of constants: data `-`, output `out`), for the front
    /// ends that set the values themselves (the studio) or compare given
    /// flags with the defaults (`--plan`).
    pub fn defaults(out: &str) -> Result<IdentifyArgs, clap::Error> {
        let cli = Cli::try_parse_from(["lifted", "identify", "--data", "-", "--out", out])?;
        match cli.command {
            Command::Identify(a) => Ok(a),
            _ => Err(clap::Error::raw(
                clap::error::ErrorKind::InvalidSubcommand,
                "internal: not an identify command line",
            )),
        }
    }
}

/// `lifted delay`.
#[derive(Debug, Args)]
pub struct DelayArgs {
    /// Data CSV (inputs held `--hold` samples, outputs sampled every `--output-period`).
    #[arg(long)]
    pub data: String,
    /// Columns and layout.
    #[command(flatten)]
    pub columns: DataArgs,
    /// Input hold m in base periods (every input).
    #[arg(long, default_value_t = 1)]
    pub hold: usize,
    /// Lifted lags L of the impulse-response estimate.
    #[arg(long, default_value_t = 8)]
    pub lags: usize,
    /// Significance threshold in standard errors.
    #[arg(long, default_value_t = 3.0)]
    pub sigmas: f64,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// Closed-loop set-ups (`lifted closedloop --setup`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SetupArg {
    /// Eq. (10): G = (I − Ĥ₁)⁻¹Ĥ₂ from H₁ (r₁ → y) and H₂ (r₂ → y).
    General,
    /// Eq. (11): G = Ĥ₁(I − Ĥ₁)⁻¹K⁻¹ from H₁ and the controller.
    Controller,
    /// Eq. (12): G = Ĥ₂(I − KĤ₂)⁻¹ from H₂ and the controller.
    Compensator,
}

/// `lifted closedloop`.
#[derive(Debug, Args)]
pub struct ClosedloopArgs {
    /// Set-up whose recovery formula is used.
    #[arg(long, value_enum)]
    pub setup: SetupArg,
    /// Model file of Ĥ₁, the identified map from the set-point r₁ to y.
    #[arg(long)]
    pub h1: Option<String>,
    /// Model file of Ĥ₂, the identified map from the plant-input excitation r₂ to y.
    #[arg(long)]
    pub h2: Option<String>,
    /// Controller model file K (u = K(r₁ − y) + r₂).
    #[arg(long)]
    pub controller: Option<String>,
    /// Keep the full interconnection (no minimal realisation of the recovered plant).
    #[arg(long)]
    pub no_minreal: bool,
    /// Output model file of the recovered plant Ĝ.
    #[arg(long)]
    pub out: String,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// Receding-horizon laws (`lifted mpc --law`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MpcLaw {
    /// Dynamic matrix control on the step-response coefficients (eqs. 8.6–8.9).
    Dmc,
    /// The same law on the state-space realisation of P/Δ (eqs. 8.10–8.14; GPC-equivalent).
    Gpc,
}

/// `lifted mpc`.
#[derive(Debug, Args)]
pub struct MpcArgs {
    /// Discrete model file the controller is designed on.
    #[arg(long)]
    pub model: String,
    /// Plant model file the loop is simulated with (default: the model).
    #[arg(long)]
    pub plant: Option<String>,
    /// Control law.
    #[arg(long, value_enum, default_value = "gpc")]
    pub law: MpcLaw,
    /// Prediction horizon h (fast samples; thesis §8.3: 12).
    #[arg(long, default_value_t = 12)]
    pub horizon: usize,
    /// Control horizon m ≤ h.
    #[arg(long, default_value_t = 3)]
    pub control_horizon: usize,
    /// DMC step-response truncation N ≥ h (default 4h).
    #[arg(long)]
    pub truncation: Option<usize>,
    /// Diagonal output weight Q: one value for all outputs or one per output (default 1).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub output_weight: Vec<f64>,
    /// Diagonal move weight R: one value for all inputs or one per input (default 1).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub move_weight: Vec<f64>,
    /// Lower input limits (one value or one per input); the QP is solved when a limit binds.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub u_min: Vec<f64>,
    /// Upper input limits.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub u_max: Vec<f64>,
    /// Largest input move |Δu| per sample.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub du_max: Vec<f64>,
    /// Lower limits on the predicted outputs.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub y_min: Vec<f64>,
    /// Upper limits on the predicted outputs.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub y_max: Vec<f64>,
    /// Dual-rate inferential MPC: OUTPUT=n samples the output every n fast samples (repeatable or comma separated).
    #[arg(long)]
    pub output_period: Vec<String>,
    /// Slow single-rate MPC: design on the hold model at n·T and update every n samples.
    #[arg(long)]
    pub slow: Option<usize>,
    /// Set-point steps OUTPUT=VALUE applied at --step-at (the other outputs' set-points stay at
    /// the operating point, 0 for a model without one; repeatable or comma separated).
    #[arg(long, allow_hyphen_values = true)]
    pub setpoint: Vec<String>,
    /// Sample at which the set-point steps are applied.
    #[arg(long, default_value_t = 0)]
    pub step_at: usize,
    /// Length of the run in fast samples (with --setpoint).
    #[arg(long, default_value_t = 100)]
    pub steps: usize,
    /// Set-point CSV with one column per model output name (instead of --setpoint).
    #[arg(long)]
    pub reference: Option<String>,
    /// Output CSV: t, then per output r_y, y and y_measured (empty between slow samples), then the inputs.
    #[arg(long)]
    pub out: String,
    /// Also write an SVG plot of outputs, set-points and inputs.
    #[arg(long)]
    pub plot: Option<String>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// Uncertainty structures (`lifted robust --uncertainty`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum UncertaintyArg {
    /// P = P̂ + ΔW₁ (Prop. 6): T = W₁K(I + P̂K)⁻¹.
    Additive,
    /// P = (I + ΔW₁)P̂ (§9.7): T = W₁P̂K(I + P̂K)⁻¹.
    Multiplicative,
}

/// `lifted robust`.
#[derive(Debug, Args)]
pub struct RobustArgs {
    /// Model file of the model P̂ (p×m, discrete) the controller was designed on.
    #[arg(long)]
    pub model: String,
    /// Controller model file K (m×p, same sample time, negative feedback u = −K y).
    #[arg(long)]
    pub controller: String,
    /// Uncertainty weight W₁ model file (q×m additive, q×p multiplicative); default the identity.
    #[arg(long)]
    pub weight: Option<String>,
    /// True plant P for the monodromy matrix of the dual-rate loop; default the model.
    #[arg(long)]
    pub plant: Option<String>,
    /// Uncertainty structure.
    #[arg(long, value_enum, default_value = "additive")]
    pub uncertainty: UncertaintyArg,
    /// Slow output periods n (in fast samples) at which β_dr and the monodromy are evaluated.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    pub periods: Vec<usize>,
    /// Number of θ grid points of the β_dr search (golden section refines the best three).
    #[arg(long, default_value_t = 2000)]
    pub grid: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// `lifted validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// Model file (JSON).
    #[arg(long)]
    pub model: String,
    /// Validation data CSV.
    #[arg(long)]
    pub data: String,
    /// Columns and layout.
    #[command(flatten)]
    pub columns: DataArgs,
    /// Lags of the correlation tests.
    #[arg(long, default_value_t = 20)]
    pub lags: usize,
    /// Exit with code 1 if the fit of any output is below this percentage.
    #[arg(long)]
    pub min_fit: Option<f64>,
    /// Offsets: `auto` applies the model file's operating point (y = y₀ + G(u − u₀)), or removes
    /// the record's means when the file has none; `mean`/`linear` compare deviations from the
    /// record's own means/trends; `none` uses the data as they are (with the file's operating
    /// point, as `auto`). A model identified with `--detrend none` states the origin as its
    /// operating point, so `auto` scores it on the data as they are.
    #[arg(long, value_enum, default_value_t = DetrendArg::Auto)]
    pub detrend: DetrendArg,
    /// Initial state of the simulation.
    #[arg(long, value_enum, default_value_t = InitialStateArg::Estimate)]
    pub initial_state: InitialStateArg,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// Initial state of a validation's simulation (`--initial-state`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum InitialStateArg {
    /// The x₀ that fits the record best in least squares (as MATLAB's `compare`; default):
    /// a slow plant's transient from rest would otherwise dominate the fit.
    Estimate,
    /// Start from rest (x₀ = 0).
    Zero,
}

impl InitialStateArg {
    /// The validation's initial condition.
    pub fn condition(self) -> lifted_lti::InitialCondition {
        match self {
            InitialStateArg::Estimate => lifted_lti::InitialCondition::Estimate,
            InitialStateArg::Zero => lifted_lti::InitialCondition::Zero,
        }
    }
}

/// Conversion targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ConvertTo {
    /// Transfer-function matrix (printed).
    Tf,
    /// State space (printed; written with --out).
    Ss,
    /// Continuous model by inverse ZOH (d2c).
    Continuous,
    /// Discrete model by ZOH at --ts (c2d).
    Discrete,
}

/// `lifted convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Model file (JSON).
    #[arg(long)]
    pub model: String,
    /// Target form.
    #[arg(long, value_enum)]
    pub to: ConvertTo,
    /// Sample period for `--to discrete`.
    #[arg(long)]
    pub ts: Option<f64>,
    /// Write the converted model here (model file; for tf, a text file); default: print
    /// the poles, the DC gain and the matrices.
    #[arg(long)]
    pub out: Option<String>,
    /// Print the converted model file (JSON) instead of the summary.
    #[arg(long)]
    pub json: bool,
}

/// `lifted bode`.
#[derive(Debug, Args)]
pub struct BodeArgs {
    /// Model file (JSON).
    #[arg(long)]
    pub model: String,
    /// Output file: `.csv` or `.svg` (default with --omega/--omega-file: a table on stdout).
    #[arg(long)]
    pub out: Option<String>,
    /// Lowest frequency, rad/s (default: a decade below the slowest pole).
    #[arg(long, conflicts_with_all = ["omega", "omega_file"])]
    pub wmin: Option<f64>,
    /// Highest frequency, rad/s (default: Nyquist for discrete models).
    #[arg(long, conflicts_with_all = ["omega", "omega_file"])]
    pub wmax: Option<f64>,
    /// Number of log-spaced frequencies.
    #[arg(long, default_value_t = 200, conflicts_with_all = ["omega", "omega_file"])]
    pub points: usize,
    /// Evaluate at these frequencies (rad/s, comma separated) instead of a grid; a discrete
    /// model refuses frequencies above its Nyquist frequency π/T.
    #[arg(
        long,
        value_delimiter = ',',
        conflicts_with = "omega_file",
        allow_hyphen_values = true
    )]
    pub omega: Vec<f64>,
    /// Evaluate at the frequencies (rad/s) of the first column of this CSV (one per line,
    /// an optional header line).
    #[arg(long)]
    pub omega_file: Option<String>,
    /// Print JSON (frequency, magnitude, magnitude in dB, phase per channel pair) instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Confidence level of the band drawn around the response of a model that carries a
    /// parameter covariance (ARX, FIR, OE model files): ± z σ of the magnitude and the phase
    /// (first-order propagation of the covariance, z the two-sided normal quantile; MATLAB's
    /// `showConfidence`). 0: no band.
    #[arg(long, default_value_t = 0.95)]
    pub confidence: f64,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// `lifted analyze`.
#[derive(Debug, Args)]
pub struct AnalyzeArgs {
    /// Model file (JSON), discrete or continuous.
    #[arg(long)]
    pub model: String,
    /// Print JSON instead of a table (a quantity that is not defined is null and its reason
    /// is under `notes`).
    #[arg(long)]
    pub json: bool,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// `lifted lqr`.
#[derive(Debug, Args)]
pub struct LqrArgs {
    /// Discrete model file (JSON); the states are the model's own.
    #[arg(long)]
    pub model: String,
    /// State weight Q (n×n, positive semi-definite): one value (q·I), n values (the
    /// diagonal) or n rows of n values separated by `;`. Default: CᵀC (output weighting).
    #[arg(long, allow_hyphen_values = true)]
    pub q: Option<String>,
    /// Input weight R (m×m, positive definite): one value, m values or m rows separated by `;`.
    #[arg(long, default_value = "1", allow_hyphen_values = true)]
    pub r: String,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// `lifted step`.
#[derive(Debug, Args)]
pub struct StepArgs {
    /// Model file (JSON).
    #[arg(long)]
    pub model: String,
    /// Output file: `.csv` or `.svg`.
    #[arg(long)]
    pub out: String,
    /// Number of samples (default: about five time constants of the slowest pole).
    #[arg(long)]
    pub samples: Option<usize>,
    /// Time step for continuous models (default: the slowest time constant / 50).
    #[arg(long)]
    pub dt: Option<f64>,
    /// Confidence level of the band drawn around the step response of a model that carries a
    /// parameter covariance (ARX, FIR, OE, ARMAX, BJ and process model files): ± z σ of each
    /// sample (first-order propagation of the covariance, z the two-sided normal quantile;
    /// MATLAB's `showConfidence` on `stepplot`); CSV columns `…_lo`, `…_hi`. 0: no band.
    #[arg(long, default_value_t = 0.95)]
    pub confidence: f64,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// `lifted report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Model file (JSON).
    #[arg(long)]
    pub model: String,
    /// Data CSV (identification or validation record).
    #[arg(long)]
    pub data: String,
    /// Columns and layout.
    #[command(flatten)]
    pub columns: DataArgs,
    /// Lags of the correlation tests.
    #[arg(long, default_value_t = 20)]
    pub lags: usize,
    /// Offsets, as in `validate --detrend`.
    #[arg(long, value_enum, default_value_t = DetrendArg::Auto)]
    pub detrend: DetrendArg,
    /// Initial state of the simulation, as in `validate --initial-state`.
    #[arg(long, value_enum, default_value_t = InitialStateArg::Estimate)]
    pub initial_state: InitialStateArg,
    /// Output HTML file.
    #[arg(long)]
    pub out: String,
    /// Memory budget.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// `lifted reproduce`.
#[derive(Debug, Args)]
pub struct ReproduceArgs {
    /// Run only the experiment with this id (e.g. A3.2) or name.
    #[arg(long)]
    pub only: Option<String>,
    /// Directory for reproductions.json and index.html.
    #[arg(long, default_value = "target/reproductions")]
    pub out: String,
    /// List the registered experiments and exit.
    #[arg(long)]
    pub list: bool,
}
