//! Steps 1–2 (data preparation, correlations, Markov parameters) and the complete
//! identification on plain matrices: one record per input channel.

use lifted_linalg::dot;
use lifted_lti::{Identified, StateSpace};
use lifted_prbs::{CorrelationMethod, Normalization, periodic_cross_correlation_with};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::cover::{CoverData, CoverKind, CoverSettings, realize};
use crate::error::{Error, Result};
use crate::options::{MarkovEstimator, QMarkovOptions, RecordMode};

/// One experiment: input channel `l` excited alone by its held inverse PRBS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelRecord {
    /// The held PRBS `w_l(k)` applied to input channel `l`, one value per output
    /// sample (length N).
    pub input: Vec<f64>,
    /// The outputs `y^l(k)`, N × n_y (one row per sample).
    pub output: DMatrix<f64>,
}

/// Diagnostics returned with every model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// All eigenvalues of `D_q` in descending order: the diagonal of `Λ`, `Λ̃`
    /// (eq. III-25), i.e. the order-selection plot of Zhu 2000 Fig. 6 (plot on a
    /// log scale).
    pub eigenvalues: Vec<f64>,
    /// The order `r` used.
    pub order: usize,
    /// The largest-gap order suggestion (`argmax ln(λ_i/λ_{i+1})`).
    pub suggested_order: usize,
    /// Numerical rank of `D_q`.
    pub rank_dq: usize,
    /// Numerical rank of `P` (< r: the `V_b U V_dᵀ` term of eq. III-29 was added).
    pub rank_p: usize,
    /// Lemma III-1 outcome: exact cover, or least-squares cover when `D_q` is
    /// not positive semidefinite (not q-identifiable).
    pub cover: CoverKind,
    /// Smallest eigenvalue of `D_q`.
    pub min_eigenvalue: f64,
    /// Number of eigenvalues below `−eigen_tol·λ₁`.
    pub negative_eigenvalues: usize,
    /// Markov parameters estimated from the data, `H_0 … H_{q−1}`.
    pub markov_data: Vec<DMatrix<f64>>,
    /// Markov parameters of the identified model, `Ĥ_0 … Ĥ_{q−1}`.
    pub markov_model: Vec<DMatrix<f64>>,
    /// `‖Ĥ − H‖_F / ‖H‖_F` over the q Markov parameters.
    pub markov_error: f64,
    /// Output covariances of the data, `R_yy(0) … R_yy(q−1)` (eq. III-22).
    pub covariance_data: Vec<DMatrix<f64>>,
    /// The same correlations of the model's periodic steady-state response to the
    /// recorded inputs.
    pub covariance_model: Vec<DMatrix<f64>>,
    /// `‖R̂ − R‖_F / ‖R‖_F` over the q covariance parameters.
    pub covariance_error: f64,
    /// Response fit `100 (1 − ‖ŷ − y‖/‖y − ȳ‖)` on the identification record, one
    /// row per experiment, one column per output (NaN when the model has no
    /// periodic steady state).
    pub fit: DMatrix<f64>,
    /// Antisymmetry residual `‖y(k) + y(k+n_r m)‖/‖y‖` of each used period.
    pub steady_state_residual: Vec<f64>,
    /// First sample of the used period in each record.
    pub record_start: Vec<usize>,
    /// PRBS magnitude used for each channel.
    pub amplitudes: Vec<f64>,
    /// All poles of Â inside the unit circle.
    pub stable: bool,
    /// Largest pole modulus of Â.
    pub spectral_radius: f64,
    /// Spectral radius of the cover's own Â when `enforce_stability`
    /// replaced it by the stabilised estimate; `None` otherwise.
    pub stabilized_from: Option<f64>,
}

/// One experiment after validation: the used period and what was read from it.
struct Prepared {
    input: Vec<f64>,
    output: DMatrix<f64>,
    amplitude: f64,
    phase: usize,
    start: usize,
    residual: f64,
}

/// Lags from which [`CorrelationMethod::Auto`] prefers the FFT: the direct
/// sums cost ≈ 2·lags·N flops in vectorised dot products, the FFT route two
/// complex transforms of length N (≈ 10 N log₂N flops at lower efficiency);
/// measured crossover on N = 81 900 (bench `correlations` of lifted-benches):
/// direct wins up to ≈ 4 log₂N lags.
const DIRECT_LAGS_PER_LOG2N: f64 = 4.0;

/// Circular correlation `R(τ) = (1/c) Σ_k x(k+τ) y(k)` at the lags
/// `τ = 0 … q−1` (`pos`) and, if `negative`, `τ = 0, −1 … −(q−1)` (`neg`, read
/// `R(−τ) = R(N−τ)`). Only these lags are used by the estimators, so
/// [`CorrelationMethod::Auto`] computes them directly, O(N·q), when that is
/// cheaper than the full O(N log N) FFT correlation of `lifted-prbs`
/// (cached plan); `Direct` always takes the lag-limited sums, `Fft` always
/// the FFT.
struct Lagged {
    pos: Vec<f64>,
    neg: Vec<f64>,
}

fn corr(
    x: &[f64],
    y: &[f64],
    c: f64,
    q: usize,
    negative: bool,
    method: CorrelationMethod,
) -> Result<Lagged> {
    let n = x.len();
    let q = q.min(n);
    let lags = if negative { 2 * q } else { q };
    let direct = match method {
        CorrelationMethod::Direct => true,
        CorrelationMethod::Fft => false,
        CorrelationMethod::Auto => {
            n < lifted_prbs::FFT_THRESHOLD
                || (lags as f64) <= DIRECT_LAGS_PER_LOG2N * (n as f64).log2()
        }
    };
    if direct {
        let s = 1.0 / c;
        // Σ_k x((k+τ) mod N) y(k), split at the wrap.
        let pos = (0..q)
            .map(|t| s * (dot(&x[t..], &y[..n - t]) + dot(&x[..t], &y[n - t..])))
            .collect();
        // Σ_k x((k−τ) mod N) y(k) = R(N−τ).
        let neg = if negative {
            (0..q)
                .map(|t| s * (dot(&x[..n - t], &y[t..]) + dot(&x[n - t..], &y[..t])))
                .collect()
        } else {
            Vec::new()
        };
        return Ok(Lagged { pos, neg });
    }
    let full = periodic_cross_correlation_with(x, y, Normalization::Divisor(c), method)?;
    let pos = full[..q].to_vec();
    let neg = if negative {
        (0..q).map(|t| full[(n - t) % n]).collect()
    } else {
        Vec::new()
    };
    Ok(Lagged { pos, neg })
}

/// `g(τ) = (1/c) Σ_k y((k+τ) mod N) v(k)`, τ < q, for `v` non-zero only at
/// `k ≡ phase (mod n_r)`.
fn impulse_train_corr(y: &[f64], v: &[f64], nr: usize, phase: usize, c: f64, q: usize) -> Vec<f64> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let n = y.len();
            let mut g = vec![0.0; q.min(n)];
            for k in (phase..n).step_by(nr.max(1)) {
                let vk = v[k] / c;
                // y(k … k+q−1) with the wrap past N − 1 to the start.
                let head = g.len().min(n - k);
                let (g_head, g_tail) = g.split_at_mut(head);
                for (gt, yv) in g_head.iter_mut().zip(&y[k..k + head]) {
                    *gt = yv.mul_add(vk, *gt);
                }
                for (gt, yv) in g_tail.iter_mut().zip(y) {
                    *gt = yv.mul_add(vk, *gt);
                }
            }
            g
        },
    )
}

fn column(m: &DMatrix<f64>, j: usize) -> &[f64] {
    let n = m.nrows();
    &m.as_slice()[j * n..(j + 1) * n]
}

fn check_finite_record(experiment: usize, r: &ChannelRecord) -> Result<()> {
    if let Some(sample) = r.input.iter().position(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            experiment,
            what: "input",
            sample,
            channel: experiment,
        });
    }
    let n = r.output.nrows();
    if let Some(k) = r.output.as_slice().iter().position(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            experiment,
            what: "output",
            sample: k % n,
            channel: k / n,
        });
    }
    Ok(())
}

/// Antisymmetry residual `‖y(k) + y(k+N/2)‖ / ‖y‖` over one period.
fn antisymmetry_residual(y: &DMatrix<f64>) -> f64 {
    let n = y.nrows();
    let half = n / 2;
    let mut num = 0.0;
    let mut den = 0.0;
    for j in 0..y.ncols() {
        let c = column(y, j);
        for k in 0..half {
            let s = c[k] + c[k + half];
            num += s * s;
        }
        den += c.iter().map(|v| v * v).sum::<f64>();
    }
    if den > 0.0 { (num / den).sqrt() } else { 0.0 }
}

fn prepare(
    experiment: usize,
    rec: &ChannelRecord,
    opts: &QMarkovOptions,
    period: usize,
) -> Result<Prepared> {
    let len = rec.input.len();
    if rec.output.nrows() != len {
        return Err(Error::DimensionMismatch {
            what: "record",
            expected: format!("{len} output rows (one per input sample)"),
            got: format!("{}", rec.output.nrows()),
        });
    }
    check_finite_record(experiment, rec)?;
    let start = match opts.record {
        RecordMode::OnePeriod => {
            if len != period {
                if len < period {
                    return Err(Error::RecordTooShort {
                        experiment,
                        len,
                        period,
                    });
                }
                return Err(Error::WrongPeriodLength {
                    experiment,
                    expected: period,
                    got: len,
                });
            }
            0
        }
        RecordMode::LastPeriod => {
            if len < period {
                return Err(Error::RecordTooShort {
                    experiment,
                    len,
                    period,
                });
            }
            len - period
        }
    };
    let input: Vec<f64> = rec.input[start..].to_vec();
    let mut output = rec.output.rows(start, period).into_owned();
    let amplitude = match &opts.amplitudes {
        Some(a) => a[experiment],
        None => input[0].abs(),
    };
    if !(amplitude.is_finite() && amplitude > 0.0) {
        return Err(Error::InvalidAmplitude {
            channel: experiment,
            value: amplitude,
        });
    }
    let tol = 1e-9 * amplitude;
    if let Some(k) = input.iter().position(|v| (v.abs() - amplitude).abs() > tol) {
        return Err(Error::NotPrbs {
            experiment,
            reason: format!(
                "sample {k} is {} but the PRBS takes the values ±{amplitude}",
                input[k]
            ),
        });
    }
    let half = period / 2;
    if let Some(sample) = (0..half).find(|&k| (input[k] + input[k + half]).abs() > tol) {
        return Err(Error::PeriodMismatch {
            experiment,
            half_period: half,
            sample,
        });
    }
    // Hold phase: every change of the input happens at a generation instant.
    let nr = opts.hold;
    let mut phase = None;
    for k in 0..period {
        let prev = input[(k + period - 1) % period];
        if (input[k] - prev).abs() > tol {
            let ph = k % nr;
            match phase {
                None => phase = Some(ph),
                Some(p) if p != ph => {
                    return Err(Error::NotPrbs {
                        experiment,
                        reason: format!(
                            "the input changes at samples {k} and at phase {p} modulo n_r = {nr}: not held n_r samples"
                        ),
                    });
                }
                Some(_) => {}
            }
        }
    }
    let phase = phase.unwrap_or(0);
    if opts.remove_mean {
        for mut col in output.column_iter_mut() {
            let mean = col.mean();
            col.add_scalar_mut(-mean);
        }
    }
    let residual = antisymmetry_residual(&output);
    if residual > opts.steady_state_tol {
        return Err(Error::NotSteadyState {
            experiment,
            residual,
            tol: opts.steady_state_tol,
        });
    }
    Ok(Prepared {
        input,
        output,
        amplitude,
        phase,
        start,
        residual,
    })
}

/// `R_yy(τ)` summed over the experiments (eq. III-22), τ < q, normalised by 1/(2m).
/// Uses `n_y(n_y+1)/2` circular correlations per experiment (`R_ji(τ) = R_ij(−τ)`).
fn output_covariances(
    outputs: &[&DMatrix<f64>],
    q: usize,
    m: usize,
    method: CorrelationMethod,
) -> Result<Vec<DMatrix<f64>>> {
    let ny = outputs[0].ncols();
    let mut ryy = vec![DMatrix::zeros(ny, ny); q];
    for y in outputs {
        for i in 0..ny {
            for j in i..ny {
                let r = corr(
                    column(y, i),
                    column(y, j),
                    2.0 * m as f64,
                    q,
                    i != j,
                    method,
                )?;
                for (tau, rt) in ryy.iter_mut().enumerate().take(r.pos.len()) {
                    rt[(i, j)] += r.pos[tau];
                    if i != j {
                        rt[(j, i)] += r.neg[tau];
                    }
                }
            }
        }
    }
    Ok(ryy)
}

/// Markov parameters of one channel (column l of every `H_τ`).
fn channel_markov(p: &Prepared, opts: &QMarkovOptions, m: usize) -> Result<Vec<DVector<f64>>> {
    let q = opts.q;
    let nr = opts.hold;
    let ny = p.output.ncols();
    let a2 = p.amplitude * p.amplitude;
    let mut h = vec![DVector::zeros(ny); q];
    match opts.markov {
        MarkovEstimator::HoldDeconvolution => {
            // The input at its generation instants only (an impulse train).
            let v: Vec<f64> = p
                .input
                .iter()
                .enumerate()
                .map(|(k, &x)| if k % nr == p.phase { x } else { 0.0 })
                .collect();
            let c = 2.0 * m as f64 * a2;
            for i in 0..ny {
                let y = column(&p.output, i);
                let g = if opts.correlation == CorrelationMethod::Fft {
                    corr(y, &v, c, q, false, opts.correlation)?.pos
                } else {
                    // Only every n_r-th sample of v is non-zero: the q lags
                    // cost O(q N / n_r), below both general routes.
                    impulse_train_corr(y, &v, nr, p.phase, c, q)
                };
                // h(τ) = g(τ) − g(τ−1) + h(τ−n_r), negative arguments zero.
                let mut hi = vec![0.0; q];
                for tau in 0..q {
                    let mut val = g[tau];
                    if tau >= 1 {
                        val -= g[tau - 1];
                    }
                    if tau >= nr {
                        val += hi[tau - nr];
                    }
                    hi[tau] = val;
                }
                for (ht, v) in h.iter_mut().zip(&hi) {
                    ht[i] = *v;
                }
            }
        }
        MarkovEstimator::PrintedIII23 => {
            let w0 = lifted_prbs::held_autocorrelation(opts.prbs_order, nr, p.amplitude, 0)?;
            for i in 0..ny {
                let r = corr(
                    column(&p.output, i),
                    &p.input,
                    2.0 * m as f64,
                    q,
                    false,
                    opts.correlation,
                )?
                .pos;
                for (ht, v) in h.iter_mut().zip(&r) {
                    ht[i] = v / w0;
                }
            }
        }
    }
    Ok(h)
}

/// Periodic steady-state response of a discrete model to one period of `u`
/// (N × n_w): `x₀ = (I − A^N)⁻¹ x_N` with `x_N` the state after one period from
/// rest. `None` when `I − A^N` is singular or the numbers overflow.
fn periodic_response(model: &StateSpace, u: &DMatrix<f64>) -> Result<Option<DMatrix<f64>>> {
    let n = model.order();
    let first = model.lsim(u, None, None)?;
    let last = u.nrows() - 1;
    let xn = model.a() * first.x.row(last).transpose() + model.b() * u.row(last).transpose();
    // A^N by repeated squaring.
    let mut pow = DMatrix::<f64>::identity(n, n);
    let mut base = model.a().clone();
    let mut e = u.nrows();
    while e > 0 {
        if e & 1 == 1 {
            pow = &pow * &base;
        }
        base = &base * &base;
        e >>= 1;
    }
    let lhs = DMatrix::<f64>::identity(n, n) - pow;
    if !lhs.iter().all(|v| v.is_finite()) {
        return Ok(None);
    }
    let Ok(x0) = lifted_linalg::solve(&lhs, &DMatrix::from_column_slice(n, 1, xn.as_slice()))
    else {
        return Ok(None);
    };
    let x0 = DVector::from_column_slice(x0.as_slice());
    Ok(Some(model.lsim(u, Some(&x0), None)?.y))
}

/// Spectral radius of Â and whether it is below 1; [`Error::UnstableCover`] when it
/// is not and `require` is set (erratum Z-9).
fn check_stability(model: &StateSpace, require: bool) -> Result<(bool, f64)> {
    let spectral_radius = model.poles()?.iter().map(|p| p.norm()).fold(0.0, f64::max);
    let stable = spectral_radius < 1.0;
    if !stable && require {
        return Err(Error::UnstableCover { spectral_radius });
    }
    Ok((stable, spectral_radius))
}

fn rel_error(model: &[DMatrix<f64>], data: &[DMatrix<f64>]) -> f64 {
    let num: f64 = model
        .iter()
        .zip(data)
        .map(|(a, b)| (a - b).norm_squared())
        .sum();
    let den: f64 = data.iter().map(|b| b.norm_squared()).sum();
    (num / den).sqrt()
}

/// The weighted multirate q-Markov Cover of Zhu 2000 §III.C from one steady-state
/// record per input channel (spec A1.4). `ts` is the output period `T` (the model's
/// sample time). Returns the cover as a discrete [`StateSpace`] at `ts` and its
/// [`Diagnostics`].
///
/// Steps: validate and cut each record (one period `N = 2 n_r m`; the input must be
/// the held inverse PRBS `±a_l`, antisymmetric with half period `n_r m`; the output
/// must pass the antisymmetry test, erratum Z-12); `R_yy(τ)` (III-22) and the Markov
/// parameters (hold-deconvolution, erratum Z-8, or III-23 as printed); `W(τ)` from
/// the closed form of `lifted-prbs` (corrected II-10, 1/(2m), errata Z-2, Z-6, Z-7);
/// then [`realize`]; finally stability (Z-9), Markov and covariance matching and the
/// response fit.
///
/// # Complexity
/// Correlations: per experiment `n_y(n_y+1)/2` output correlations and `n_y`
/// input–output ones, only at the q lags used: directly in O(N q) when
/// `q ≤ 4 log₂N` lags (twice that for cross terms), else by the FFT of
/// `lifted-prbs` in O(N log N) with a cached plan; the hold-deconvolution
/// correlation with the impulse train costs O(N q / n_r). Cover: O((q n_y)³).
/// Diagnostics: two simulations of N samples per
/// experiment, O(N r (r + n_w + n_y)), plus the same correlations again.
///
/// # Errors
/// Named errors for every rejected input: [`Error::NoExperiments`],
/// [`Error::ChannelCount`], [`Error::DimensionMismatch`], [`Error::NonFinite`],
/// [`Error::RecordTooShort`], [`Error::WrongPeriodLength`], [`Error::PeriodMismatch`],
/// [`Error::NotPrbs`], [`Error::NotSteadyState`], [`Error::InvalidAmplitude`],
/// [`Error::LagsOutOfRange`], [`Error::OrderExceedsRank`], [`Error::InvalidOption`],
/// [`Error::InvalidWeighting`], [`Error::UnstableCover`]; `lifted_linalg::Error::TooLarge`
/// (wrapped in [`Error::Linalg`]) when q lags need more memory than the budget.
pub fn identify_records(
    records: &[ChannelRecord],
    ts: f64,
    opts: &QMarkovOptions,
) -> Result<Identified<Diagnostics>> {
    let (m, period) = opts.validate()?;
    if records.is_empty() {
        return Err(Error::NoExperiments);
    }
    let nw = records.len();
    if let Some(a) = &opts.amplitudes
        && a.len() != nw
    {
        return Err(Error::ChannelCount {
            what: "amplitudes",
            expected: nw,
            got: a.len(),
        });
    }
    if !(ts.is_finite() && ts > 0.0) {
        return Err(Error::InvalidOption {
            what: "ts",
            reason: format!("the output period must be positive and finite, got {ts}"),
        });
    }
    let ny = records[0].output.ncols();
    if ny == 0 {
        return Err(Error::DimensionMismatch {
            what: "outputs",
            expected: "at least one output channel".into(),
            got: "0".into(),
        });
    }
    for (l, r) in records.iter().enumerate() {
        if r.output.ncols() != ny {
            return Err(Error::DimensionMismatch {
                what: "outputs",
                expected: format!("{ny} output channels in every experiment"),
                got: format!("{} in experiment {l}", r.output.ncols()),
            });
        }
    }
    check_cover_size(opts.q, ny, nw)?;
    let prepared: Vec<Prepared> = records
        .iter()
        .enumerate()
        .map(|(l, r)| prepare(l, r, opts, period))
        .collect::<Result<_>>()?;

    // Step 2: correlations and Markov parameters.
    let outputs: Vec<&DMatrix<f64>> = prepared.iter().map(|p| &p.output).collect();
    let ryy = output_covariances(&outputs, opts.q, m, opts.correlation)?;
    let mut markov = vec![DMatrix::zeros(ny, nw); opts.q];
    for (l, p) in prepared.iter().enumerate() {
        let h = channel_markov(p, opts, m)?;
        for (tau, hl) in h.into_iter().enumerate() {
            markov[tau].set_column(l, &hl);
        }
    }
    // W(τ) = diag_l R_w(τ) for τ < n_r (closed form, corrected II-10), 0 beyond.
    let mut weighting = vec![DVector::zeros(nw); opts.q];
    for (tau, w) in weighting.iter_mut().enumerate().take(opts.hold.min(opts.q)) {
        for (l, p) in prepared.iter().enumerate() {
            w[l] = lifted_prbs::held_autocorrelation(
                opts.prbs_order,
                opts.hold,
                p.amplitude,
                tau as i64,
            )?;
        }
    }
    let data = CoverData {
        ryy,
        markov,
        weighting,
    };
    let settings = CoverSettings {
        order: opts.order,
        max_auto_order: opts.max_auto_order,
        output_weighting: opts.output_weighting.clone(),
        weighting: opts.weighting,
        eigen_tol: opts.eigen_tol,
        rank_tol: opts.rank_tol,
        rotation: opts.rotation.clone(),
        enforce_stability: opts.enforce_stability,
    };
    let real = realize(&data, &settings)?;
    let model = StateSpace::new(
        real.a.clone(),
        real.b.clone(),
        real.c.clone(),
        real.d.clone(),
        Some(ts),
    )?;

    // Stability (erratum Z-9).
    let (stable, spectral_radius) = check_stability(&model, opts.require_stable)?;

    // Diagnostics: Markov and covariance parameters matched, response fit.
    let markov_model = model.markov_parameters(opts.q - 1)?;
    let markov_error = rel_error(&markov_model, &data.markov);
    let mut fit = DMatrix::from_element(nw, ny, f64::NAN);
    let mut simulated = Vec::with_capacity(nw);
    for (l, p) in prepared.iter().enumerate() {
        let mut u = DMatrix::zeros(period, nw);
        u.set_column(l, &DVector::from_column_slice(&p.input));
        if let Some(yh) = periodic_response(&model, &u)? {
            for i in 0..ny {
                let y = column(&p.output, i);
                let mean = y.iter().sum::<f64>() / y.len() as f64;
                let e: f64 = column(&yh, i)
                    .iter()
                    .zip(y)
                    .map(|(a, b)| (a - b).powi(2))
                    .sum();
                let v: f64 = y.iter().map(|b| (b - mean).powi(2)).sum();
                fit[(l, i)] = 100.0 * (1.0 - (e / v).sqrt());
            }
            simulated.push(yh);
        }
    }
    let (covariance_model, covariance_error) = if simulated.len() == nw {
        let refs: Vec<&DMatrix<f64>> = simulated.iter().collect();
        let cm = output_covariances(&refs, opts.q, m, opts.correlation)?;
        let err = rel_error(&cm, &data.ryy);
        (cm, err)
    } else {
        (Vec::new(), f64::NAN)
    };

    let diagnostics = Diagnostics {
        eigenvalues: real.eigenvalues,
        order: real.order,
        suggested_order: real.suggested_order,
        rank_dq: real.rank_dq,
        rank_p: real.rank_p,
        cover: real.cover,
        min_eigenvalue: real.min_eigenvalue,
        negative_eigenvalues: real.negative_eigenvalues,
        markov_data: data.markov,
        markov_model,
        markov_error,
        covariance_data: data.ryy,
        covariance_model,
        covariance_error,
        fit,
        steady_state_residual: prepared.iter().map(|p| p.residual).collect(),
        record_start: prepared.iter().map(|p| p.start).collect(),
        amplitudes: prepared.iter().map(|p| p.amplitude).collect(),
        stable,
        spectral_radius,
        stabilized_from: real.stabilized_from,
    };
    Ok(Identified { model, diagnostics })
}

/// The memory of the cover for q lags, n_y outputs and n_w inputs, checked
/// against `lifted_linalg::budget::MemoryBudget` before it is formed
/// (`lifted_linalg::Error::TooLarge`, wrapped): D_q and its weighted copy,
/// R_q and their eigenvectors (four qn_y × qn_y matrices), W_q
/// ((q n_w)²) and H_q (q n_y × q n_w, twice).
fn check_cover_size(q: usize, ny: usize, nw: usize) -> Result<()> {
    use lifted_linalg::budget::{MemoryBudget, Size};
    let need = match (q.checked_mul(ny), q.checked_mul(nw)) {
        (Some(n), Some(w)) => Size::matrices(4, n, n)
            .plus(Size::matrices(1, w, w))
            .plus(Size::matrices(2, n, w)),
        _ => Size::OVERFLOW,
    };
    Ok(MemoryBudget::default().check("the q-Markov cover (q lags)", need)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn first_order(a: f64) -> StateSpace {
        StateSpace::new(
            DMatrix::from_element(1, 1, a),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap()
    }

    #[test]
    fn lags_beyond_memory_are_too_large() {
        assert!(check_cover_size(60, 2, 2).is_ok());
        let e = check_cover_size(500_000, 2, 2).unwrap_err();
        assert!(
            matches!(e, Error::Linalg(lifted_linalg::Error::TooLarge { .. })),
            "{e}"
        );
        let e = check_cover_size(usize::MAX / 2, 4, 4).unwrap_err();
        assert!(
            matches!(e, Error::Linalg(lifted_linalg::Error::TooLarge { .. })),
            "{e}"
        );
    }

    #[test]
    fn hold_times_period_overflow_is_an_option_error() {
        let opts = QMarkovOptions {
            hold: usize::MAX / 4,
            ..Default::default()
        };
        assert!(matches!(
            opts.validate(),
            Err(Error::InvalidOption { what: "hold", .. })
        ));
    }

    #[test]
    fn unstable_cover_is_reported() {
        let g = first_order(1.02);
        assert!(matches!(
            check_stability(&g, true),
            Err(Error::UnstableCover { spectral_radius }) if (spectral_radius - 1.02).abs() < 1e-12
        ));
        let (stable, rho) = check_stability(&g, false).unwrap();
        assert!(!stable && (rho - 1.02).abs() < 1e-12);
        assert_eq!(
            check_stability(&first_order(0.5), true).unwrap(),
            (true, 0.5)
        );
    }

    #[test]
    fn periodic_response_is_periodic() {
        let g = first_order(0.9);
        let u = DMatrix::from_fn(40, 1, |k, _| if k < 20 { 1.0 } else { -1.0 });
        let y = periodic_response(&g, &u).unwrap().unwrap();
        // Antisymmetric input, antisymmetric steady state.
        for k in 0..20 {
            assert!((y[(k, 0)] + y[(k + 20, 0)]).abs() < 1e-12);
        }
        assert!(antisymmetry_residual(&y) < 1e-12);
    }

    #[test]
    fn hold_deconvolution_recovers_fir() {
        // y = h * w exactly periodic for an FIR h: the deconvolution is exact up to
        // the O(1/m) off-peak autocorrelation of the PRBS.
        let prbs = lifted_prbs::InversePrbs::new(&lifted_prbs::InversePrbsOptions {
            order: 10,
            amplitude: 1.5,
            hold: 3,
            taps: None,
        })
        .unwrap();
        let w = prbs.one_period();
        let n = w.len();
        let h = [0.3, 0.5, -0.2, 0.1];
        let y = DMatrix::from_fn(n, 1, |k, _| {
            h.iter()
                .enumerate()
                .map(|(j, hj)| hj * w[(k + n - j) % n])
                .sum()
        });
        let p = Prepared {
            input: w,
            output: y,
            amplitude: 1.5,
            phase: 0,
            start: 0,
            residual: 0.0,
        };
        let opts = QMarkovOptions {
            q: 8,
            hold: 3,
            prbs_order: 10,
            ..Default::default()
        };
        let est = channel_markov(&p, &opts, 1023).unwrap();
        for (tau, e) in est.iter().enumerate() {
            let truth = h.get(tau).copied().unwrap_or(0.0);
            assert!(
                (e[0] - truth).abs() < 5e-3,
                "tau {tau}: {} vs {truth}",
                e[0]
            );
        }
    }

    #[test]
    fn lag_limited_correlations_match_the_fft() {
        let n = 1000;
        let x: Vec<f64> = (0..n).map(|k| ((k * 37 + 11) % 17) as f64 - 8.0).collect();
        let y: Vec<f64> = (0..n)
            .map(|k| ((k * 13 + 5) % 23) as f64 * 0.5 - 3.0)
            .collect();
        let q = 25;
        let d = corr(&x, &y, 7.0, q, true, CorrelationMethod::Direct).unwrap();
        let f = corr(&x, &y, 7.0, q, true, CorrelationMethod::Fft).unwrap();
        for t in 0..q {
            assert!((d.pos[t] - f.pos[t]).abs() < 1e-9, "lag {t}");
            assert!((d.neg[t] - f.neg[t]).abs() < 1e-9, "lag -{t}");
        }
        // The impulse-train shortcut equals the general sums.
        let (nr, phase) = (4, 1);
        let v: Vec<f64> = (0..n)
            .map(|k| if k % nr == phase { x[k] } else { 0.0 })
            .collect();
        let g = impulse_train_corr(&y, &v, nr, phase, 3.0, q);
        let r = corr(&y, &v, 3.0, q, false, CorrelationMethod::Direct).unwrap();
        for (t, (a, b)) in g.iter().zip(&r.pos).enumerate() {
            assert!((a - b).abs() < 1e-9, "lag {t}");
        }
    }
}
