//! Li (2001) thesis §5.3.1 and the §5.3.2 stand-in, spec A3.7: a 2×2
//! stirred-tank model at T = 1 with y₁ sampled every 5 and y₂ every 1
//! (J = 5), RBS inputs, coloured noise, var-SNR 5 per output channel
//! (spec §0). Lifted N4SID (6 block rows) with the causal D̄, principal 5th
//! root and LS for B (the reference implementation's route).
//!
//! Simulation: lifted-sim's `stirred_tank_5_3_1` fixture in open loop (its
//! output sampling (5, 0) and (1, 0) gives the multirate data set), the
//! fixture's 2×2 noise model driven by two white sources and scaled per
//! output after it is generated so that var(noise-free y_i)/var(v_i) = 5 on
//! the record; two independent RBS ±1 inputs from lifted-prbs
//! (`a3_subspace::rbs2`).
//!
//! Numbers (8 seeds): median e_step(300) G₁₁ 0.074, G₂₁ 0.104, G₂₂ 0.019,
//! G₁₂ 0.39; worst |pole − 0.9868| 0.0037. §5.3.2 stand-in (6 seeds): worst
//! validation fit 82.4% / 90.4% (medians 86.4% / 92.6%).
//!
//! Default change 2026-11-25 (lifted subspace step by shift invariance
//! with the means removed, instead of the state sequences): median e_step
//! G₁₁ 0.074 → 0.048, G₂₁ 0.104 → 0.109, G₂₂ 0.019 → 0.028, G₁₂ 0.39 → 0.30;
//! worst pole error 0.0037 → 0.0024; §5.3.2 stand-in worst validation fit
//! 82.4 % → 76.9 % (y₁) and 90.4 % → 85.4 % (y₂), still above 70 % / 85 %.

use lifted_lti::{Dataset, StateSpace};
use lifted_multirate::{LiftedIdOptions, Ordering, ProcedureOptions, identify_multirate};
use lifted_pem::{PemOptions, refine_pem};
use lifted_sim::plants::stirred_tank_5_3_1;
use lifted_sim::{Excitation, SimOutput, SnrDefinition};
use lifted_subspace::{Feedthrough, OrderSelection, Record};
use nalgebra::DMatrix;

use crate::a3_lifting::{median, step_errors};
use crate::a3_subspace::{rbs2, validation_fit};
use crate::report::{CurveStyle, FigureData, step_curves};
use crate::{Check, Reproduction};

type BoxResult<T> = Result<T, Box<dyn std::error::Error>>;

/// The §5.3.1 plant (lifted-sim reference fixture; L-14: not the §2.6.2 or
/// §7.8.2 model).
pub(crate) fn plant_531() -> BoxResult<StateSpace> {
    Ok(stirred_tank_5_3_1()?.plant)
}

/// Simulates `len` samples with lifted-sim: RBS u (seeded by `seed`), the
/// fixture's noise at var-SNR `snr` (noise seed `seed`), y₁ every 5 and y₂
/// every 1.
fn simulate(len: usize, snr: f64, seed: u64) -> BoxResult<SimOutput> {
    let fx = stirred_tank_5_3_1()?;
    let noise = fx
        .noise_spec(snr, SnrDefinition::Variance, seed)
        .ok_or("the §5.3.1 fixture has a noise model")?;
    let sim = fx.simulator()?.with_noise(noise)?;
    Ok(sim.simulate(&Excitation::input(rbs2(len, seed)?))?)
}

fn fit_model(data: &Dataset, rows: usize) -> BoxResult<StateSpace> {
    let opts = ProcedureOptions {
        identification: LiftedIdOptions {
            order: OrderSelection::Fixed(4),
            past: rows,
            future: rows,
            ..Default::default()
        },
        ordering: Ordering::TimeMajor,
        ..Default::default()
    };
    Ok(identify_multirate(data, None, &opts)?.fast)
}

/// §5.3.1 over 8 seeds.
pub fn run_531() -> BoxResult<Reproduction> {
    let mut rep = Reproduction::new("A3.7", "§5.3.1: MIMO multirate (y₁ every 5, y₂ every 1)");
    let truth = plant_531()?;
    let mut errs: Vec<DMatrix<f64>> = Vec::new();
    let mut refined: Vec<DMatrix<f64>> = Vec::new();
    let mut pole_err: Vec<f64> = Vec::new();
    let mut failures = Vec::new();
    let mut shown: Option<(u64, StateSpace, StateSpace)> = None;
    for seed in 0..8u64 {
        let out = simulate(10_000, 5.0, 5310 + seed)?;
        match fit_model(&out.data, 6) {
            Ok(g) => {
                errs.push(step_errors(&g, &truth, 300)?);
                let pem = refine_pem(
                    &g,
                    None,
                    &[Record {
                        u: out.data.u(),
                        y: out.data.y(),
                        instrument: None,
                    }],
                    &[],
                    &PemOptions {
                        feedthrough: Feedthrough::Zero,
                        ..Default::default()
                    },
                )?;
                refined.push(step_errors(&pem.model, &truth, 300)?);
                if shown.is_none() {
                    shown = Some((seed, g.clone(), pem.model.clone()));
                }
                let d = g
                    .poles()?
                    .iter()
                    .map(|p| (p - num_complex::Complex64::new(0.9868, 0.0)).norm())
                    .fold(f64::INFINITY, f64::min);
                pole_err.push(d);
            }
            Err(e) => failures.push(format!("seed {seed}: {e}")),
        }
    }
    rep.check(Check::holds(
        "every seed gives a stable fast model",
        failures.join("; "),
        failures.is_empty(),
    ));
    let med = |i: usize, j: usize| median(&errs.iter().map(|e| e[(i, j)]).collect::<Vec<_>>());
    let worst = |i: usize, j: usize| errs.iter().map(|e| e[(i, j)]).fold(0.0, f64::max);
    for (name, i, j, bound, ri) in [
        ("G11", 0, 0, 0.15, "0.09"),
        ("G21", 1, 0, 0.15, "0.06"),
        ("G22", 1, 1, 0.15, "0.03"),
        ("G12", 0, 1, 0.6, "0.42"),
    ] {
        rep.check(
            Check::below(format!("median e_step(300) {name}"), med(i, j), bound).with_note(
                format!(
                    "spec A3.7; RI median {ri} (8 seeds, i = 6){}",
                    if name == "G12" {
                        "; G12 is a known weak channel seen only at the slow rate"
                    } else {
                        ""
                    }
                ),
            ),
        );
        rep.figure(format!("worst e_step {name}"), worst(i, j));
    }
    // Prediction-error refinement of the same fast models on the multirate
    // record (cost on the measured samples only; issue 15). Reached: ratios
    // G11 0.992, G21 0.651, G22 0.839, G12 0.658; G12 median 0.194 (with
    // the dimensionless Marquardt damping of 2026-11-26; before it, with
    // fewer iterations converged: G11 0.997, G21 0.767, G22 0.918, G12
    // 0.665, G12 median 0.196) — under the 0.2 target by a small
    // margin.
    let med_r = |i: usize, j: usize| median(&refined.iter().map(|e| e[(i, j)]).collect::<Vec<_>>());
    for (name, i, j) in [("G11", 0, 0), ("G21", 1, 0), ("G22", 1, 1), ("G12", 0, 1)] {
        rep.check(
            Check::below(
                format!("PEM-refined median e_step(300) {name} / two-step median"),
                med_r(i, j) / med(i, j),
                1.0,
            )
            .with_note("prediction-error refinement (refine_pem, default cost) lowers every channel's median; the output-error cost lowered G11/G21/G12 but raised G22 (ratio 1.32) and left G12 at 0.274"),
        );
        rep.figure(format!("PEM-refined median e_step {name}"), med_r(i, j));
    }
    rep.check(
        Check::below("PEM-refined median e_step(300) G12", med_r(0, 1), 0.2)
            .with_note("issue 15 target < 0.2, reached 0.194 (0.196 before the 2026-11-26 damping change; two-step route 0.30 here, RI 0.42)"),
    );
    let wp = pole_err.iter().cloned().fold(0.0, f64::max);
    rep.check(
        Check::below(
            "worst |fast pole nearest 0.9868 − 0.9868| (every seed)",
            wp,
            0.005,
        )
        .with_note("spec A3.7 pole tolerance, asserted on every seed"),
    );
    rep.figure("worst |pole - 0.9868|", wp);
    if let Some((seed, g, pem)) = &shown {
        for fig in figs_5_3_to_5_6(&truth, g, pem, *seed)? {
            rep.plot(fig);
        }
    }
    Ok(rep)
}

/// Thesis Figs. 5.3–5.6: step responses of the true and the estimated fast
/// models, one figure per channel G11, G12, G21, G22, over the 300 samples
/// of the e_step check, for the first seed's models (two-step route and its
/// prediction-error refinement).
fn figs_5_3_to_5_6(
    truth: &StateSpace,
    g: &StateSpace,
    pem: &StateSpace,
    seed: u64,
) -> BoxResult<Vec<FigureData>> {
    [
        ("5.3", "G11", 0, 0),
        ("5.4", "G12", 0, 1),
        ("5.5", "G21", 1, 0),
        ("5.6", "G22", 1, 1),
    ]
    .into_iter()
    .map(|(fig, name, o, i)| -> BoxResult<FigureData> {
        let mut f = FigureData::new(
            format!("li-fig{}", fig.replace('.', "-")),
            format!(
                "Li (2001) Fig. {fig}: step responses of the true model ({name}) and the \
                     estimated fast model, §5.3.1 (y₁ every 5, y₂ every 1, var-SNR 5, order 4; \
                     seed {seed}: lifted N4SID + 5th root, and its PEM refinement)"
            ),
            "t (samples, T = 1)",
            format!("y{} (unit step on u{})", o + 1, i + 1),
        );
        f.curves = step_curves(
            &[
                ("true", truth, CurveStyle::Line),
                ("estimated (two-step)", g, CurveStyle::Line),
                ("estimated (PEM-refined)", pem, CurveStyle::Line),
            ],
            o,
            i,
            300,
        )?;
        Ok(f)
    })
    .collect()
}

/// The §5.3.2 stand-in: identify on 3600 multirate samples, validate on
/// 1350 fast-sampled samples against the noise-free output, 6 seeds.
pub fn run_532() -> BoxResult<Reproduction> {
    let mut rep = Reproduction::new("A3.7b", "§5.3.2 stand-in: validation on fast-sampled data");
    let mut f1 = Vec::new();
    let mut f2 = Vec::new();
    for seed in 0..6u64 {
        let total = 3600 + 1350;
        let out = simulate(total, 5.0, 5320 + seed)?;
        let g = fit_model(&out.data.slice(0..3600)?, 10)?;
        // validation on the fast-sampled last 1350 samples (200 transient
        // samples discarded) against the noise-free output
        let fit = validation_fit(&g, out.u(), &out.y_clean, 3800)?;
        f1.push(fit[0]);
        f2.push(fit[1]);
    }
    let min1 = f1.iter().cloned().fold(f64::INFINITY, f64::min);
    let min2 = f2.iter().cloned().fold(f64::INFINITY, f64::min);
    rep.check(
        Check::above("worst validation fit y₁ (%)", min1, 70.0)
            .with_note("spec A3.7: ≥ 70% every seed; RI worst 78%, median 88%"),
    );
    rep.check(
        Check::above("worst validation fit y₂ (%)", min2, 85.0)
            .with_note("spec A3.7: ≥ 85% every seed; RI worst 90%, median 93%"),
    );
    rep.figure("median fit y1", median(&f1));
    rep.figure("median fit y2", median(&f2));
    Ok(rep)
}
