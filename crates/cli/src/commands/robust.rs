//! `lifted robust`: the stability-robustness measures of thesis ch. 9
//! (Prop. 6, Cor. 1, §9.7) from lifted-mpc — β_sr = ‖T‖∞, β_dr at each slow
//! output period n (alias closed form) — and the spectral radius of the
//! monodromy matrix of the dual-rate inferential loop (`DualRateLoop`).
//!
//! Cost: β_sr O(iterations · order³); β_dr O(grid · n · order³) per n; the
//! monodromy O(n · order³) per n.

use lifted_lti::StateSpace;
use lifted_mpc::{
    Beta, DualRateLoop, RobustnessOptions, Uncertainty, beta_dr, beta_sr, robustness_map,
};
use nalgebra::DMatrix;
use serde_json::json;

use crate::args::{RobustArgs, UncertaintyArg};
use crate::error::{CliResult, Context, input};
use lifted_cli::service::models::read_model;

/// One slow period's figures.
struct PeriodRow {
    n: usize,
    beta: Beta,
    rho: f64,
}

/// W₁ from the file, or the identity of the size the structure needs.
fn weight(a: &RobustArgs, model: &StateSpace, u: Uncertainty) -> CliResult<StateSpace> {
    if let Some(path) = &a.weight {
        return Ok(read_model(path)?.model);
    }
    let q = match u {
        Uncertainty::Additive => model.n_inputs(),
        Uncertainty::Multiplicative => model.n_outputs(),
    };
    StateSpace::gain(DMatrix::identity(q, q), model.ts()).ctx("identity weight W1")
}

/// `lifted robust`.
pub fn robust_cmd(a: &RobustArgs) -> CliResult<()> {
    if a.periods.is_empty() {
        return Err(input("--periods needs at least one slow period"));
    }
    if let Some(&bad) = a.periods.iter().find(|&&n| n == 0) {
        return Err(input(format!(
            "--periods: slow period {bad} is not a positive number of fast samples"
        )));
    }
    let uncertainty = match a.uncertainty {
        UncertaintyArg::Additive => Uncertainty::Additive,
        UncertaintyArg::Multiplicative => Uncertainty::Multiplicative,
    };
    let model = read_model(&a.model)?.model;
    let k = read_model(&a.controller)?.model;
    let plant = match &a.plant {
        Some(p) => read_model(p)?.model,
        None => model.clone(),
    };
    let w = weight(a, &model, uncertainty)?;
    // Checks sizes, sample times and nominal stability once, with one message.
    robustness_map(&model, &k, &w, uncertainty).ctx("robustness map T")?;
    let sr = beta_sr(&model, &k, &w, uncertainty).ctx("beta_sr")?;
    let opts = RobustnessOptions {
        grid: a.grid,
        ..RobustnessOptions::default()
    };
    let mut rows = Vec::with_capacity(a.periods.len());
    for &n in &a.periods {
        let beta =
            beta_dr(&model, &k, &w, uncertainty, n, &opts).ctx(format!("beta_dr n = {n}"))?;
        let rho = DualRateLoop::new(&plant, &model, &k, n)
            .and_then(|l| l.spectral_radius())
            .ctx(format!("dual-rate loop n = {n}"))?;
        rows.push(PeriodRow { n, beta, rho });
    }
    let unc = match uncertainty {
        Uncertainty::Additive => "additive",
        Uncertainty::Multiplicative => "multiplicative",
    };
    if a.json {
        let v = json!({
            "uncertainty": unc,
            "beta_sr": {"value": sr.value, "theta": sr.theta},
            "periods": rows.iter().map(|r| json!({
                "n": r.n,
                "beta_dr": r.beta.value,
                "theta": r.beta.theta,
                "robustly_stable": r.beta.value < 1.0,
                "monodromy_spectral_radius": r.rho,
                "stable": r.rho < 1.0,
            })).collect::<Vec<_>>(),
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&v).ctx("JSON of the robustness measures")?
        );
        return Ok(());
    }
    println!(
        "{unc} uncertainty: beta_sr = {:.6} at theta = {:.6} rad/sample",
        sr.value, sr.theta
    );
    println!(
        "{:>4}  {:>10}  {:>9}  {:>16}  {:>10}  {:>6}",
        "n", "beta_dr", "theta", "small gain (<1)", "rho(Phi)", "stable"
    );
    for r in &rows {
        println!(
            "{:>4}  {:>10.6}  {:>9.6}  {:>16}  {:>10.6}  {:>6}",
            r.n,
            r.beta.value,
            r.beta.theta,
            if r.beta.value < 1.0 { "yes" } else { "no" },
            r.rho,
            if r.rho < 1.0 { "yes" } else { "no" }
        );
    }
    Ok(())
}
