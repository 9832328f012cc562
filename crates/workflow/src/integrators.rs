//! Integrators: poles on or within a tolerance δ of the unit circle
//! (integrating and double-integrating plants: a mass driven by a force, a
//! motor's position, a level fed by a flow) are taken as marginal, not as
//! instability, when the data put them there.
//!
//! **The tolerance** ([`IdentificationOptions::integrator_tolerance`](crate::IdentificationOptions::integrator_tolerance);
//! default δ = [`INTEGRATOR_TOLERANCE_SCALE`]/N, N the samples of the
//! longest record). Two facts fix its scale, neither tuned on a benchmark:
//!
//! * statistics: a pole on the unit circle is estimated with an error of
//!   order 1/N, not 1/√N (superconsistency of unit roots: Dickey & Fuller
//!   1979; Sims, Stock & Watson 1990). For the first-order case the
//!   asymptotic distribution of N(ρ̂ − 1) has its 99 % quantile at 2.03
//!   (Fuller 1996, Table 10.A.1), so an estimate beyond 1 + 2/N is
//!   unlikely to be an integrator and one within it cannot be told from
//!   one;
//! * numerics: a model with ρ(A) ≤ 1 + 2/N grows by at most
//!   (1 + 2/N)^N ≤ e² ≈ 7.4 over the record, so its simulation and the
//!   x₀ regression stay well conditioned (the regressions accept a growth
//!   up to 6.7e7, `lifted_subspace::MAX_REGRESSOR_GROWTH`).
//!
//! **What it changes.** Where the refinement needs a stable start (the
//! zero-padded shift of the refine module's `stabilized_start`) an estimate
//! with ρ(A) < 1 + δ is kept instead of being pulled inside the circle (on
//! the EMPS drive record the zero-padded shift moved the double pole at
//! 1.00003 to a model whose validation fit was 45 % against 94.5 %), and
//! the prediction-error iterations may keep ρ(A) < 1 + δ (their predictor
//! A − KC stays strictly stable). An estimate with ρ(A) ≥ 1 + δ is
//! unstable and handled as before. With `--stable` (a stable model asked
//! for) the marginal poles are moved just inside, to radius 1 − δ (the
//! eigenvectors kept; a mode of time constant N/2 samples, which
//! integrates over the record), and the prediction-error polish with every
//! iterate stable then re-fits the model; a stable model cannot hold an
//! integrator, and the warning says so. Every model's diagnostics list its
//! poles within δ of the circle under `integrators`.

use lifted_lti::{Dataset, StateSpace};
use nalgebra::DMatrix;
use serde_json::json;

use crate::options::{IdentificationOptions, WorkflowOptions};

/// The default integrator tolerance is this over the longest record's
/// samples N: the 99 % quantile (2.03) of the asymptotic distribution of
/// N(ρ̂ − 1) for a unit root (Fuller 1996, Table 10.A.1), rounded; a
/// model within it grows by at most e² over the record (module docs).
pub const INTEGRATOR_TOLERANCE_SCALE: f64 = 2.0;

/// The integrator tolerance δ of a run on `sets`: the options' value, or
/// [`INTEGRATOR_TOLERANCE_SCALE`]/N for the longest record of N samples (0
/// without samples); with how it was obtained, for the diagnostics.
pub(crate) fn tolerance(opts: &WorkflowOptions, sets: &[Dataset]) -> (f64, String) {
    tolerance_for(opts, sets.iter().map(Dataset::len).max().unwrap_or(0))
}

/// [`tolerance`] for records whose longest has `longest` samples (a
/// streamed record, before it is loaded).
pub(crate) fn tolerance_for(opts: &WorkflowOptions, longest: usize) -> (f64, String) {
    tolerance_of(&opts.identification, longest)
}

/// The spectral radius below which the automatic order rules take a model
/// as they take a stable one (`routes::first_stable`): 1 + δ, the
/// integrator tolerance of the records, so that an integrating plant's
/// marginal model at the rule's order is kept as the refinement keeps it;
/// 1 under `--stable`.
pub(crate) fn stability_bound(id: &IdentificationOptions, sets: &[Dataset]) -> f64 {
    stability_bound_for(id, sets.iter().map(Dataset::len).max().unwrap_or(0))
}

/// [`stability_bound`] for records whose longest has `longest` samples.
pub(crate) fn stability_bound_for(id: &IdentificationOptions, longest: usize) -> f64 {
    if id.stable {
        return 1.0;
    }
    1.0 + tolerance_of(id, longest).0
}

fn tolerance_of(id: &IdentificationOptions, longest: usize) -> (f64, String) {
    match id.integrator_tolerance {
        Some(d) => (
            d,
            "given (integrator_tolerance, --integrator-tolerance)".into(),
        ),
        None if longest == 0 => (0.0, "no samples".into()),
        None => (
            INTEGRATOR_TOLERANCE_SCALE / longest as f64,
            format!(
                "{INTEGRATOR_TOLERANCE_SCALE}/N, N = {longest} samples of the longest record: a unit root's estimate is within O(1/N) of 1 (N(rho - 1) beyond 2.03 with probability 1 %, Dickey-Fuller), and rho <= 1 + 2/N grows by at most e^2 over the record"
            ),
        ),
    }
}

/// The poles of `model` within `delta` of the unit circle
/// (| |λ| − 1 | ≤ δ, a relative 1e-9 of slack for rounding).
pub(crate) fn marginal_poles(model: &StateSpace, delta: f64) -> Vec<nalgebra::Complex<f64>> {
    if model.order() == 0 || model.ts().is_none() {
        return Vec::new();
    }
    model
        .poles()
        .map(|p| {
            p.iter()
                .copied()
                .filter(|z| (z.norm() - 1.0).abs() <= delta * (1.0 + 1e-9) + 1e-12)
                .collect()
        })
        .unwrap_or_default()
}

/// Whether `model` is marginal: unstable (ρ(A) ≥ 1) but within `delta`
/// (ρ(A) < 1 + δ).
pub(crate) fn is_marginal(model: &StateSpace, delta: f64) -> bool {
    crate::validate::spectral_radius(model).is_ok_and(|r| r >= 1.0 && r < 1.0 + delta)
}

/// `model` with its eigenvalues on or outside the unit circle moved to
/// radius 1 − δ (reflected through the circle and capped there,
/// `lifted_linalg::reflect_into_unit_disc`, eigenvectors and the other
/// eigenvalues kept); when its eigenvectors are too ill-conditioned for
/// that (a double integrator is nearly defective), A scaled by
/// (1 − δ)/ρ(A) instead, which moves every pole radially by at most 2δ
/// relative. `None` when δ is not in (0, 1) or the poles cannot be had.
pub(crate) fn moved_inside(model: &StateSpace, delta: f64) -> Option<StateSpace> {
    if !(delta > 0.0 && delta < 1.0) {
        return None;
    }
    let radius = 1.0 - delta;
    let a = model.a();
    let moved = match lifted_linalg::reflect_into_unit_disc(a, radius) {
        Ok(Some(m)) => m,
        _ => {
            let rho = crate::validate::spectral_radius(model).ok()?;
            if !(rho.is_finite() && rho > 0.0) {
                return None;
            }
            a * (radius / rho)
        }
    };
    let moved: DMatrix<f64> = moved;
    StateSpace::new(
        moved,
        model.b().clone(),
        model.c().clone(),
        model.d().clone(),
        model.ts(),
    )
    .ok()
}

/// `diagnostics.integrators` of the model written: the tolerance, how it
/// was obtained, the poles within it of the unit circle (integrators at
/// z ≈ 1, undamped oscillations elsewhere on the circle) and what was done
/// with them (`note`).
pub(crate) fn annotate(
    diagnostics: &mut serde_json::Value,
    model: &StateSpace,
    delta: f64,
    derivation: &str,
    note: Option<&str>,
) {
    let poles = marginal_poles(model, delta);
    let list: Vec<serde_json::Value> = poles
        .iter()
        .map(|z| json!({"re": z.re, "im": z.im, "abs": z.norm()}))
        .collect();
    if let Some(obj) = diagnostics.as_object_mut() {
        let mut entry = json!({
            "tolerance": delta,
            "derivation": derivation,
            "count": poles.len(),
            "poles": list,
        });
        if let (Some(n), Some(e)) = (note, entry.as_object_mut()) {
            e.insert("note".into(), json!(n));
        }
        obj.insert("integrators".into(), entry);
    }
}

/// `diagnostics.integrators` of the model a run writes
/// ([`annotate`], with what was done with its marginal poles), and with
/// `--stable` a warning when they were moved inside.
pub(crate) fn report(
    opts: &WorkflowOptions,
    longest: usize,
    model: &StateSpace,
    diagnostics: &mut serde_json::Value,
) {
    let (delta, derivation) = tolerance_for(opts, longest);
    let count = marginal_poles(model, delta).len();
    let moved = diagnostics.get("integrators_moved_inside") == Some(&json!(true));
    let note = if moved {
        Some(format!(
            "a stable model cannot represent an integrator: --stable moved the poles on or outside the unit circle just inside, to radius 1 - {delta:.2e} (time constant about 1/tolerance samples: the model integrates over the record's length but not beyond), then refined it with every iterate stable; without --stable they stay on the circle"
        ))
    } else if count > 0 {
        Some(
            "poles within the tolerance of the unit circle are integrators (the plant integrates) or undamped modes, kept where the data put them, not treated as instability"
                .to_string(),
        )
    } else {
        None
    };
    annotate(diagnostics, model, delta, &derivation, note.as_deref());
    if moved && let Some(n) = note {
        crate::diagnostics::push_warning(diagnostics, format!("the plant has integrator(s): {n}"));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The order rules' bound: 1 + 2/N by default, 1 + the given tolerance,
    /// 1 under `--stable`.
    #[test]
    fn the_stability_bound_is_one_plus_the_integrator_tolerance() {
        let d = Dataset::single_rate(1.0, DMatrix::zeros(500, 1), DMatrix::zeros(500, 1))
            .expect("record");
        let sets = [d];
        let mut id = IdentificationOptions::default();
        assert!((stability_bound(&id, &sets) - (1.0 + 2.0 / 500.0)).abs() < 1e-15);
        id.integrator_tolerance = Some(1e-3);
        assert!((stability_bound(&id, &sets) - 1.001).abs() < 1e-15);
        id.stable = true;
        assert_eq!(stability_bound(&id, &sets), 1.0);
    }
}
