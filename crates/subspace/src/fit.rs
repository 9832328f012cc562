//! Fit at order: steps 2–4 of [`crate::identify`] on a compressed factor —
//! the weighted SVD (N4SID, MOESP and CVA as one weighted SVD, thesis §2.5,
//! Van Overschee & De Moor's unifying theorem), (A, C) by shift invariance
//! or the state sequences, (B, D, x₀) by the chosen route and the noise
//! model. One compression serves every order: each fit costs O(k³) plus
//! the (B, D, x₀) step.

use lifted_linalg::{RankTolerance, SortOrder, dare, lstsq, mul_blocks, pinv, svd_left, sym_eig};
use lifted_lti::{OperatingPoint, StateSpace};
use std::time::Instant;

use nalgebra::{DMatrix, DVector};

use crate::checks::{candidate_orders, thread_count, validate_on};
use crate::error::{Error, Result, check_exciting};
use crate::estimated::InitialState;
use crate::estimated::Record;
use crate::hankel::{HankelFactor, HankelLayout};
use crate::model::{BdRoute, Diagnostics, Experiment, NoiseCovariances, Profile, SubspaceModel};
use crate::numerics::{Scale, ac_from_gamma, rows, scaled_basis, vstack};
use crate::oblique::Projector;
use crate::options::{BdEstimate, Method, OrderSelection, SubspaceOptions, SystemEstimate};
use crate::order::{
    OrderCriterion, OrderReport, gap_order, gap_values, information_criterion_values,
    simulation_error, svc_values,
};
use crate::projection::bd_from_projection;
use crate::records::{compressed, need_records, records_of, remove_means};
use crate::regress::{Route, estimate_x0, output_error_route};
use lifted_linalg::spectral_radius;

/// CVA's weight W₁ = [(Y_f/U_f⊥)(Y_f/U_f⊥)ᵀ]^{−1/2} and its inverse
/// (eigenvalues floored at 1e-14 λ_max; erratum L-1). O(k³).
fn cva_weights(pr: &Projector<'_>, yf: &DMatrix<f64>) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let yfp = pr.perp_future_inputs(yf)?;
    let e = sym_eig(&(&yfp * yfp.transpose()), SortOrder::Descending)?;
    let lmax = e.values.iter().cloned().fold(0.0, f64::max);
    let floor = (lmax * 1e-14).max(f64::MIN_POSITIVE);
    let mut w1 = DMatrix::zeros(e.values.len(), e.values.len());
    let mut w1i = w1.clone();
    for (i, &lam) in e.values.iter().enumerate() {
        let v = e.vectors.column(i);
        let lam = lam.max(floor);
        w1 += v * v.transpose() / lam.sqrt();
        w1i += v * v.transpose() * lam.sqrt();
    }
    Ok((w1, w1i))
}

/// The weighted subspace of one compressed data set (steps 2–3 of
/// [`crate::identify`]), from which a model of any order is fitted.
struct Subspace<'a> {
    l: &'a DMatrix<f64>,
    layout: HankelLayout,
    /// Projections of `l` (structured when L is triangular).
    projector: Projector<'a>,
    /// Oblique projection Φ = 𝓜 W_p (scaled data).
    phi: DMatrix<f64>,
    /// Its map 𝓜.
    map: DMatrix<f64>,
    /// Whether 𝓜 = L₃₂ L₂₂⁻¹ exactly (structured factor, well-conditioned
    /// L₂₂), so that the projection (B, D) can reuse it.
    map_triangular: bool,
    /// Left singular vectors and singular values of W₁ Φ W₂.
    u: DMatrix<f64>,
    s: Vec<f64>,
    /// W₁⁻¹ (CVA only).
    w1_inv: Option<DMatrix<f64>>,
}

impl Subspace<'_> {
    /// Γ = W₁⁻¹ U₁ S₁^{1/2} of order n (scaled data).
    fn gamma(&self, n: usize) -> DMatrix<f64> {
        let gamma = scaled_basis(&self.u, &self.s, n);
        match &self.w1_inv {
            Some(w1i) => w1i * gamma,
            None => gamma,
        }
    }
}

/// A model of one order, in the original units of the data.
pub(crate) struct Fit {
    /// Constant output offsets per record (output-error regression with
    /// mean removal), else empty.
    pub(crate) offsets: Vec<DVector<f64>>,
    pub(crate) a: DMatrix<f64>,
    pub(crate) b: DMatrix<f64>,
    pub(crate) c: DMatrix<f64>,
    pub(crate) d: DMatrix<f64>,
    pub(crate) x0: Vec<DVector<f64>>,
    pub(crate) stabilized: bool,
    /// Γ of the scaled data (for the noise model).
    pub(crate) gamma: DMatrix<f64>,
    /// Route of (B, D, x₀).
    pub(crate) bd_route: BdRoute,
    /// A fallback taken (the route refused and why).
    pub(crate) fallback: Option<String>,
}

/// Step 4 of [`crate::identify`] for order n: (A, C) by shift invariance or from
/// the state sequences, (B, D, x₀) by the output-error regression on the
/// records or from the state-sequence regression (then x₀ alone from the
/// records, when present). O(k³) plus O(N n_y (n_u n³ + p²)) for the
/// regressions.
fn fit_order(
    sub: &Subspace<'_>,
    n: usize,
    opts: &SubspaceOptions,
    records: Option<&[Record<'_>]>,
    scale: Scale,
) -> Result<Fit> {
    let (nu, ny) = (sub.layout.nu, sub.layout.ny);
    let gamma = sub.gamma(n);
    // (B, D, x₀) by output-error regression on the records (in memory only),
    // for (A, C) of the scaled data: C in original units first.
    let output_error = |enforce: bool, gamma: DMatrix<f64>| -> Result<Fit> {
        let (a, c, stabilized) = ac_from_gamma(&gamma, ny, enforce, opts.marginal_tolerance)?;
        let c = c * scale.y;
        let recs = need_records(records)?;
        let bd = output_error_route(
            &a,
            &c,
            recs,
            &opts.feedthrough,
            opts.initial_state,
            Route {
                offsets: opts.remove_means,
                allow_modal: true,
                threads: thread_count(opts.threads),
            },
        )?;
        let offsets = if opts.remove_means {
            bd.offsets
        } else {
            Vec::new()
        };
        Ok(Fit {
            a,
            b: bd.b,
            c,
            d: bd.d,
            x0: bd.x0,
            offsets,
            stabilized,
            gamma,
            bd_route: BdRoute::OutputError,
            fallback: None,
        })
    };
    let projection = |enforce: bool, gamma: DMatrix<f64>| -> Result<Fit> {
        let (a, c, stabilized) = ac_from_gamma(&gamma, ny, enforce, opts.marginal_tolerance)?;
        let mask = opts.feedthrough.mask(ny, nu)?;
        let (b, d) = bd_from_projection(
            sub.l,
            &sub.layout,
            sub.map_triangular.then_some(&sub.map),
            &a,
            &c,
            &gamma,
            &mask,
        )?;
        let (b, c, d) = scale.unscale(b, c, d);
        let x0 = initial_states(&a, &b, &c, &d, opts.initial_state, records, n)?;
        Ok(Fit {
            a,
            b,
            c,
            d,
            x0,
            offsets: Vec::new(),
            stabilized,
            gamma,
            bd_route: BdRoute::Projection,
            fallback: None,
        })
    };
    let shift = |enforce: bool, gamma: DMatrix<f64>| -> Result<Fit> {
        match (opts.bd, records.is_some()) {
            (BdEstimate::OutputError, _) => output_error(enforce, gamma),
            // Auto: an A too unstable for the output-error regression over
            // the record (low SNR) still gets (B, D) from the projection.
            (BdEstimate::Auto, true) => match output_error(enforce, gamma.clone()) {
                Err(e @ Error::UnstableEstimate { .. }) => {
                    let mut fit = projection(enforce, gamma)?;
                    fit.fallback = Some(format!(
                        "(B, D) from the projection on the compressed data: the output-error regression was refused ({e})"
                    ));
                    Ok(fit)
                }
                other => other,
            },
            (BdEstimate::Projection, _) | (BdEstimate::Auto, false) => projection(enforce, gamma),
        }
    };
    match opts.system {
        SystemEstimate::ShiftInvariance => shift(opts.enforce_stability, gamma),
        SystemEstimate::StateSequence => {
            let mask = opts.feedthrough.mask(ny, nu)?;
            let ls = ac_from_states(sub.l, &sub.layout, &gamma, &sub.map, &mask)?;
            if opts.enforce_stability && spectral_radius(&ls.a)? >= 1.0 + opts.marginal_tolerance {
                return shift(true, gamma);
            }
            let (b, c, d) = scale.unscale(ls.b, ls.c, ls.d);
            let x0 = initial_states(&ls.a, &b, &c, &d, opts.initial_state, records, n)?;
            Ok(Fit {
                a: ls.a,
                b,
                c,
                d,
                x0,
                offsets: Vec::new(),
                stabilized: false,
                gamma,
                bd_route: BdRoute::StateSequence,
                fallback: None,
            })
        }
    }
}

/// x₀ per record for a model whose (B, D) did not come from the
/// output-error regression: estimated from the records when they are in
/// memory, none when streaming.
fn initial_states(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
    initial_state: InitialState,
    records: Option<&[Record<'_>]>,
    n: usize,
) -> Result<Vec<DVector<f64>>> {
    Ok(match initial_state {
        InitialState::Estimate => match records {
            Some(r) => estimate_x0(a, b, c, d, r)?,
            None => Vec::new(),
        },
        InitialState::Zero => vec![DVector::zeros(n); records.map_or(0, |r| r.len())],
    })
}

/// The values of the options' order criterion for orders 1..=`cap` and, for
/// AIC/AICc/BIC, the model of every order (None where the fit failed).
fn order_values(
    sub: &Subspace<'_>,
    cap: usize,
    opts: &SubspaceOptions,
    records: Option<&[Record<'_>]>,
    scale: Scale,
    columns: usize,
) -> Result<(OrderReport, Vec<Option<Fit>>)> {
    let (nu, ny) = (sub.layout.nu, sub.layout.ny);
    let criterion = opts.order_criterion;
    let mut fits = Vec::new();
    let values = match criterion {
        OrderCriterion::Svc => {
            // Canonical correlations: the CVA singular values.
            let cc = if opts.method == Method::Cva {
                sub.s.clone()
            } else {
                let yf = rows(sub.l, sub.layout.yf());
                let (w1, _) = cva_weights(&sub.projector, &yf)?;
                lifted_linalg::singular_values(&(w1 * sub.projector.perp_future_inputs(&sub.phi)?))?
                    .iter()
                    .cloned()
                    .collect()
            };
            svc_values(&cc, cap, ny, nu, columns)
        }
        c if c.needs_models() => {
            let recs = need_records(records)?;
            let (values, models) = information_criterion_values(
                c,
                cap,
                recs,
                (ny, nu),
                &opts.feedthrough,
                opts.initial_state,
                |n| fit_order(sub, n, opts, records, scale),
                |f: &Fit| simulation_error(&f.a, &f.b, &f.c, &f.d, recs, &f.x0),
            )?;
            fits = models;
            values
        }
        _ => gap_values(&sub.s, cap),
    };
    Ok((OrderReport::new(criterion, values), fits))
}

/// Steps 2–5 of [`crate::identify`] on the compressed data L of the scaled data
/// (records, in original units, only for the output-error (B, D, x₀)
/// regressions and the AIC-type criteria; `None` when streaming).
pub(crate) fn from_factor(
    factor: HankelFactor,
    layout: &HankelLayout,
    opts: &SubspaceOptions,
    records: Option<&[Record<'_>]>,
    scale: Scale,
    compress_s: f64,
) -> Result<SubspaceModel> {
    Ok(from_factor_parts(factor, layout, opts, records, scale, compress_s)?.fit)
}

/// [`from_factor`] keeping L, Γ and the oblique map.
pub(crate) fn from_factor_parts(
    factor: HankelFactor,
    layout: &HankelLayout,
    opts: &SubspaceOptions,
    records: Option<&[Record<'_>]>,
    scale: Scale,
    compress_s: f64,
) -> Result<Factored> {
    let t1 = Instant::now();
    let HankelFactor {
        l,
        columns,
        report: compression,
        certified_rcond,
    } = factor;
    let compression_flops = compression.flops;
    let (p, f) = (layout.past, layout.future);
    let layout = *layout;
    let max_order = (f - 1) * layout.ny;
    let sub = subspace_of(&l, certified_rcond, layout, opts)?;
    let svd_s = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let singular_values = singular_values_in_units(&sub.s, opts.method, scale);
    let cap = candidate_orders(opts.order, max_order);
    let suggested_order = gap_order(&sub.s, cap);
    let (order_selection, mut fits) = order_values(&sub, cap, opts, records, scale, columns)?;
    let n = match opts.order {
        OrderSelection::Fixed(n) => n,
        OrderSelection::Gap { .. } => order_selection.selected,
    };
    if n > sub.s.len() {
        return Err(Error::OrderTooLarge {
            order: n,
            max: sub.s.len(),
        });
    }
    let fit = match fits.get_mut(n - 1).and_then(Option::take) {
        Some(fit) => fit,
        None => fit_order(&sub, n, opts, records, scale)?,
    };

    let noise = if opts.noise_model {
        noise_part(&l, &layout, &fit.gamma, &sub.map, &fit, scale)
    } else {
        NoisePart::default()
    };
    let spectral_radius = spectral_radius(&fit.a)?;
    let gamma = fit.gamma;
    let map = sub.map;
    let model = StateSpace::new(fit.a, fit.b, fit.c, fit.d, Some(opts.ts))?;
    let fitted = SubspaceModel {
        model,
        kalman_gain: noise.kalman_gain,
        noise: noise.covariances,
        x0: fit.x0,
        output_offsets: fit.offsets,
        operating_point: None,
        diagnostics: Diagnostics {
            method: opts.method,
            singular_values,
            order: n,
            suggested_order,
            order_selection,
            horizons: (p, f),
            columns,
            stabilized: fit.stabilized,
            noise_model_error: noise.error,
            compression_flops,
            compression,
            profile: Profile {
                compress_s,
                svd_s,
                estimate_s: t2.elapsed().as_secs_f64(),
            },
            bd_route: fit.bd_route,
            fallbacks: fit.fallback.into_iter().collect(),
            spectral_radius,
        },
    };
    Ok(Factored {
        fit: fitted,
        l,
        gamma,
        map,
    })
}

/// Step 2 alone: the singular values of the weighted projection in the
/// units of the original data (the factor's data were divided by `scale`).
pub(crate) fn weighted_singular_values(
    factor: &HankelFactor,
    layout: HankelLayout,
    opts: &SubspaceOptions,
    scale: Scale,
) -> Result<Vec<f64>> {
    let sub = subspace_of(&factor.l, factor.certified_rcond, layout, opts)?;
    Ok(singular_values_in_units(&sub.s, opts.method, scale))
}

/// N4SID's and MOESP's singular values scale with the outputs; CVA's are
/// canonical correlations.
fn singular_values_in_units(s: &[f64], method: Method, scale: Scale) -> Vec<f64> {
    let unit = if method == Method::Cva { 1.0 } else { scale.y };
    s.iter().map(|v| v * unit).collect()
}

/// Steps 2–3 of [`crate::identify`] on the factor `l` (scaled data): the
/// excitation test, the oblique projection, the weights of `opts.method`
/// and the SVD. O(k³); the projections' block tests cost nothing when
/// `certified_rcond` ([`HankelFactor::certified_rcond`]) bounds L's
/// conditioning.
fn subspace_of<'l>(
    l: &'l DMatrix<f64>,
    certified_rcond: f64,
    layout: HankelLayout,
    opts: &SubspaceOptions,
) -> Result<Subspace<'l>> {
    // Persistent excitation: the input rows [U_f; U_p] must have full rank.
    let nu_rows = (layout.past + layout.future) * layout.nu;
    let projector = Projector::new(l, layout, certified_rcond)?;
    check_exciting(
        crate::error::INPUT_ROWS,
        projector.input_rank(1e-10)?,
        nu_rows,
    )?;
    // Φ = 𝓜 W_p with W_p = [U_p; Y_p], consecutive rows of L (a view).
    let (map, map_triangular) = projector.oblique_map()?;
    let wp_rows = layout.up().start..layout.yp().end;
    let phi = if map_triangular {
        // W_p's rows of the structured L are [L₂₁ L₂₂ 0] and 𝓜 = L₃₂ L₂₂⁻¹,
        // so Φ = [𝓜 L₂₁  L₃₂  0]: one product of 𝓜 with the r_u columns
        // of L₂₁ (a quarter of the whole product at equal horizons), and
        // L₃₂ itself rather than 𝓜 L₂₂ (its rounding).
        let (ru, rw, k) = (layout.uf().end, wp_rows.end, l.nrows());
        let mut phi = DMatrix::zeros(k - rw, l.ncols());
        phi.columns_mut(0, ru)
            .copy_from(&(&map * l.view((ru, 0), (rw - ru, ru))));
        phi.columns_mut(ru, rw - ru)
            .copy_from(&l.view((rw, ru), (k - rw, rw - ru)));
        phi
    } else {
        &map * l.rows(wp_rows.start, wp_rows.len())
    };
    let (w1_inv, weighted) = match opts.method {
        Method::N4sid => (None, None),
        Method::Moesp => (None, Some(projector.perp_future_inputs(&phi)?)),
        Method::Cva => {
            let (w1, w1i) = cva_weights(&projector, &rows(l, layout.yf()))?;
            (Some(w1i), Some(w1 * projector.perp_future_inputs(&phi)?))
        }
    };
    // U and the singular values only (V is never used); N4SID's weights
    // are identities.
    let (u, s) = svd_left_trimmed(weighted.as_ref().unwrap_or(&phi))?;
    Ok(Subspace {
        l,
        layout,
        projector,
        phi,
        map,
        map_triangular,
        u,
        s: s.iter().cloned().collect(),
        w1_inv,
    })
}

/// [`svd_left`] of `m` without its trailing zero columns (those of a
/// structured factor beyond W_p: a quarter of Φ's at equal horizons), as
/// many kept as `m` has rows at least: the left singular vectors and
/// singular values of [X 0] are those of X.
fn svd_left_trimmed(m: &DMatrix<f64>) -> Result<(DMatrix<f64>, nalgebra::DVector<f64>)> {
    let rows = m.nrows();
    let used = m
        .as_slice()
        .chunks_exact(rows.max(1))
        .rposition(|c| c.iter().any(|&v| v != 0.0))
        .map_or(0, |j| j + 1)
        // At least as many columns as rows: the thin U keeps its shape.
        .max(rows);
    if used >= m.ncols() {
        return Ok(svd_left(m)?);
    }
    Ok(svd_left(&m.columns(0, used).into_owned())?)
}

/// The models of orders 1..=`cap` of one (A, C) route (`None` where the
/// fit failed).
pub(crate) type RouteModels = Vec<Option<StateSpace>>;

/// The model of every order 1..=`cap` (`None` where the fit failed) from
/// one compression of the records, with the operating point removed when
/// `opts.remove_means` (returned; y₀ includes the output offsets of each
/// order's regression only through the model's own deviations, so the
/// caller compares deviations from it). For the structure selection of
/// [`crate::select_structure`]: one O(N) compression and one weighted SVD
/// (O(k³)) shared by every route of `systems` (the (A, C) route acts only
/// after the SVD), then per route and order O(k³) plus the (B, D, x₀)
/// regression O(N q²). `only`: fit that order alone (a fixed order's
/// selection; the other entries stay `None`). The models are returned per
/// entry of `systems`, in its order (`opts.system` is not used).
pub(crate) fn models_of_orders(
    experiments: &[Experiment<'_>],
    opts: &SubspaceOptions,
    systems: &[SystemEstimate],
    cap: usize,
    only: Option<usize>,
) -> Result<(Option<OperatingPoint>, Vec<RouteModels>)> {
    validate_on(experiments, thread_count(opts.threads))?;
    let (op, owned) = if opts.remove_means {
        let (op, c) = remove_means(experiments)?;
        (Some(op), Some(c))
    } else {
        (None, None)
    };
    let exps: Vec<Experiment<'_>> = match &owned {
        Some(c) => c.iter().map(|(u, y)| Experiment { u, y }).collect(),
        None => experiments.to_vec(),
    };
    let (layout, factor, scale) = compressed(&exps, opts)?;
    let ny = layout.ny;
    let records = records_of(&exps);
    let sub = subspace_of(&factor.l, factor.certified_rcond, layout, opts)?;
    let cap = cap.min(sub.s.len()).min((layout.future - 1) * ny);
    let models = systems
        .iter()
        .map(|&system| {
            let o = SubspaceOptions {
                system,
                ..opts.clone()
            };
            (1..=cap)
                .map(|n| {
                    if only.is_some_and(|m| m != n) {
                        return None;
                    }
                    fit_order(&sub, n, &o, Some(&records), scale)
                        .ok()
                        .and_then(|f| StateSpace::new(f.a, f.b, f.c, f.d, Some(o.ts)).ok())
                })
                .collect()
        })
        .collect();
    Ok((op, models))
}

/// A model fitted from a compressed factor, with what a later (B, D)
/// re-estimate needs to recompute the noise model: L, Γ and the oblique
/// map (scaled data).
pub(crate) struct Factored {
    pub(crate) fit: SubspaceModel,
    pub(crate) l: DMatrix<f64>,
    pub(crate) gamma: DMatrix<f64>,
    pub(crate) map: DMatrix<f64>,
}

/// The noise model of a fit: covariances, Kalman gain, or why not.
#[derive(Default)]
pub(crate) struct NoisePart {
    pub(crate) covariances: Option<NoiseCovariances>,
    pub(crate) kalman_gain: Option<DMatrix<f64>>,
    pub(crate) error: Option<String>,
}

/// Q, R, S and the Kalman gain of the model `fit` (original units) from
/// the state sequences of the factor (step 5 of [`crate::identify`]).
pub(crate) fn noise_part(
    l: &DMatrix<f64>,
    layout: &HankelLayout,
    gamma: &DMatrix<f64>,
    map: &DMatrix<f64>,
    fit: &Fit,
    scale: Scale,
) -> NoisePart {
    let (bs, cs, ds) = scale.rescale(&fit.b, &fit.c, &fit.d);
    match noise_model(l, layout, gamma, map, &fit.a, &bs, &cs, &ds) {
        Ok((cov, kg)) => {
            // Back to original units: v and e scale with s_y, w not.
            let covariances = Some(NoiseCovariances {
                q: cov.q,
                r: cov.r * (scale.y * scale.y),
                s: cov.s * scale.y,
            });
            match kg {
                Ok(k) => NoisePart {
                    covariances,
                    kalman_gain: Some(k / scale.y),
                    error: None,
                },
                Err(e) => NoisePart {
                    covariances,
                    kalman_gain: None,
                    error: Some(e),
                },
            }
        }
        Err(e) => NoisePart {
            error: Some(e.to_string()),
            ..NoisePart::default()
        },
    }
}

/// The state sequence X(t) = Γ⁺Φ(t) = Γ⁺M W_p(t) (Φ = M W_p, the oblique
/// projection is a fixed linear map M of the past data) at times t and t+1,
/// and the rows u(t), y(t) (thesis §2.2–2.3). W_p(t+1) = [u(t−p+1…t);
/// y(t−p+1…t)] consists of Hankel rows, so both sequences live in the row
/// space of the compressed factor and are consecutive in time.
fn state_sequences(
    l: &DMatrix<f64>,
    lay: &HankelLayout,
    gamma: &DMatrix<f64>,
    map: &DMatrix<f64>,
) -> Result<[DMatrix<f64>; 4]> {
    let (nu, ny) = (lay.nu, lay.ny);
    let ufr = lay.uf();
    let yfr = lay.yf();
    let upr = lay.up();
    let ypr = lay.yp();
    let u_i = rows(l, ufr.start..ufr.start + nu);
    let y_i = rows(l, yfr.start..yfr.start + ny);
    // K = Γ⁺M (n × p(n_u+n_y), columns in the order of W_p = [U_p; Y_p],
    // which are consecutive rows of L): X(t) = K W_p(t) on a view of L.
    let k = pinv(gamma, RankTolerance::Default)? * map;
    debug_assert_eq!(upr.end, ypr.start);
    let (pu, py) = (upr.len(), ypr.len());
    let mut x_i = DMatrix::zeros(k.nrows(), l.ncols());
    mul_blocks(&mut x_i, false, &k, 0..pu + py, l, upr.start..ypr.end)?;
    // W_p(t+1) = [U_p rows n_u…; u(t); Y_p rows n_y…; y(t)]: four products
    // with row blocks of L instead of a stacked copy.
    let mut x_ip1 = DMatrix::zeros(k.nrows(), l.ncols());
    mul_blocks(
        &mut x_ip1,
        false,
        &k,
        0..pu - nu,
        l,
        upr.start + nu..upr.end,
    )?;
    mul_blocks(
        &mut x_ip1,
        true,
        &k,
        pu - nu..pu,
        l,
        ufr.start..ufr.start + nu,
    )?;
    mul_blocks(
        &mut x_ip1,
        true,
        &k,
        pu..pu + py - ny,
        l,
        ypr.start + ny..ypr.end,
    )?;
    mul_blocks(
        &mut x_ip1,
        true,
        &k,
        pu + py - ny..pu + py,
        l,
        yfr.start..yfr.start + ny,
    )?;
    Ok([x_i, x_ip1, u_i, y_i])
}

/// A and C from the state-sequence regression (thesis §2.3) with the
/// feedthrough mask applied per output row (§4.5).
fn ac_from_states(
    l: &DMatrix<f64>,
    lay: &HankelLayout,
    gamma: &DMatrix<f64>,
    map: &DMatrix<f64>,
    mask: &DMatrix<bool>,
) -> Result<StateLs> {
    let [x_i, x_ip1, u_i, y_i] = state_sequences(l, lay, gamma, map)?;
    let n = x_i.nrows();
    let z = vstack(&[&x_i, &u_i]);
    let ab = lstsq(&z.transpose(), &x_ip1.transpose())?.transpose();
    let a = ab.columns(0, n).into_owned();
    let b = ab.columns(n, lay.nu).into_owned();
    let mut c = DMatrix::zeros(lay.ny, n);
    let mut d = DMatrix::zeros(lay.ny, lay.nu);
    for o in 0..lay.ny {
        let allowed: Vec<usize> = (0..lay.nu).filter(|&j| mask[(o, j)]).collect();
        let mut zo = DMatrix::zeros(n + allowed.len(), x_i.ncols());
        zo.rows_mut(0, n).copy_from(&x_i);
        for (t, &j) in allowed.iter().enumerate() {
            zo.row_mut(n + t).copy_from(&u_i.row(j));
        }
        let yo = DMatrix::from_fn(y_i.ncols(), 1, |k, _| y_i[(o, k)]);
        let th = lstsq(&zo.transpose(), &yo)?;
        for s in 0..n {
            c[(o, s)] = th[(s, 0)];
        }
        for (t, &j) in allowed.iter().enumerate() {
            d[(o, j)] = th[(n + t, 0)];
        }
    }
    Ok(StateLs { a, b, c, d })
}

/// (A, B, C, D) of the state-sequence regression.
struct StateLs {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    d: DMatrix<f64>,
}

type NoiseResult = (NoiseCovariances, std::result::Result<DMatrix<f64>, String>);

/// Q, R, S from the state sequences (thesis §2.3) and the Kalman gain from
/// the filter DARE X = AXAᵀ − (AXCᵀ + S)(CXCᵀ + R)⁻¹(·)ᵀ + Q.
#[allow(clippy::too_many_arguments)]
fn noise_model(
    l: &DMatrix<f64>,
    lay: &HankelLayout,
    gamma: &DMatrix<f64>,
    map: &DMatrix<f64>,
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
) -> Result<NoiseResult> {
    let [x_i, x_ip1, u_i, y_i] = state_sequences(l, lay, gamma, map)?;
    let w = x_ip1 - a * &x_i - b * &u_i;
    let v = y_i - c * &x_i - d * &u_i;
    let cov = NoiseCovariances {
        q: &w * w.transpose(),
        r: &v * v.transpose(),
        s: &w * v.transpose(),
    };
    let kg = dare(&a.transpose(), &c.transpose(), &cov.q, &cov.r, Some(&cov.s))
        .map(|sol| sol.k.transpose())
        .map_err(|e| e.to_string());
    Ok((cov, kg))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random lower-triangular factor with a positive diagonal (the
    /// structured case of [`crate::oblique::Projector`]).
    fn lower(k: usize, seed: u64) -> DMatrix<f64> {
        let mut s = seed | 1;
        DMatrix::from_fn(k, k, |i, j| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let r = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            match i.cmp(&j) {
                std::cmp::Ordering::Greater => r,
                std::cmp::Ordering::Equal => 1.0 + r.abs(),
                std::cmp::Ordering::Less => 0.0,
            }
        })
    }

    #[test]
    fn the_structured_projection_is_the_maps_product_and_its_svd_the_full_ones() {
        for (past, future, nu, ny, seed) in [(3, 3, 1, 2, 3), (4, 2, 2, 1, 7), (2, 5, 2, 2, 11)] {
            let layout = HankelLayout {
                past,
                future,
                nu,
                ny,
            };
            let l = lower(layout.nrows(), seed);
            for method in [Method::N4sid, Method::Moesp] {
                let opts = SubspaceOptions {
                    method,
                    ..Default::default()
                };
                let sub = subspace_of(&l, 0.0, layout, &opts).unwrap();
                assert!(sub.map_triangular);
                let wp = layout.up().start..layout.yp().end;
                let product = &sub.map * l.rows(wp.start, wp.len());
                assert!((&sub.phi - &product).amax() < 1e-12 * product.amax());
                // The SVD of Φ with its zero columns, sign for sign.
                let weighted = match method {
                    Method::N4sid => sub.phi.clone(),
                    _ => sub.projector.perp_future_inputs(&sub.phi).unwrap(),
                };
                assert!(
                    weighted
                        .columns(wp.end, l.ncols() - wp.end)
                        .iter()
                        .all(|&v| v == 0.0)
                );
                let (u, s) = svd_left(&weighted).unwrap();
                assert_eq!(sub.u.shape(), u.shape());
                for (a, b) in sub.s.iter().zip(s.iter()) {
                    assert!((a - b).abs() < 1e-12 * s[0]);
                }
                let n = s.iter().filter(|&&v| v > 1e-8 * s[0]).count();
                assert!((sub.u.columns(0, n) - u.columns(0, n)).amax() < 1e-9);
            }
        }
    }

    #[test]
    fn trimming_keeps_the_thin_shape() {
        // All-zero and short matrices keep as many columns as rows.
        let zero = DMatrix::<f64>::zeros(3, 7);
        let (u, s) = svd_left_trimmed(&zero).unwrap();
        assert_eq!((u.shape(), s.len()), ((3, 3), 3));
        let mut m = DMatrix::<f64>::zeros(2, 6);
        m[(0, 0)] = 1.0;
        m[(1, 3)] = 2.0;
        let (u, s) = svd_left_trimmed(&m).unwrap();
        assert_eq!(u.shape(), (2, 2));
        assert!((s[0] - 2.0).abs() < 1e-15 && (s[1] - 1.0).abs() < 1e-15);
    }
}
