//! Spec A3.1: CVA / N4SID / MOESP on the stirred-tank model of thesis §2.6.2,
//! and the §2.6.1 stand-in (validation on fresh data).
//!
//! Set-up (spec A3.1): plant G₁₁ = 0.1416/(z−0.9868), G₁₂ = 0,
//! G₂₁ = −0.0379/(z−0.913), G₂₂ = 0.0595/(z−0.9048) (`lifted_sim::plants::
//! stirred_tank_2_6_2`); noise stand-in diag-lower [0.11/(1−0.97z⁻¹), 0;
//! −0.02/(1−0.9z⁻¹), 0.04/(1−0.86z⁻¹)]·e; two independent RBS ±1 inputs;
//! 3000 samples; SNR 5 with the spec §0 definition var(noise-free output) /
//! var(noise) per output channel (the harder reading); order 3; i = 15 block
//! rows (past = future = 15); D fixed to 0. 10 seeds, medians.

use lifted_lti::StateSpace;
use lifted_prbs::{RandomBinaryOptions, random_binary};
use lifted_sim::plants::stirred_tank_2_6_2;
use lifted_sim::{Excitation, SnrDefinition};
use lifted_subspace::{
    Experiment, Feedthrough, Method, OrderSelection, SubspaceOptions, SystemEstimate, identify,
};
use nalgebra::DMatrix;

use crate::report::{CurveStyle, FigureData, step_curves};
use crate::{Check, Reproduction};

type BoxResult<T> = Result<T, Box<dyn std::error::Error>>;

/// Seeds of the Monte-Carlo runs (spec §0: medians over ≥ 10 seeds).
pub const SEEDS: u64 = 10;

/// Two independent RBS ±1 channels (seeded per channel).
pub fn rbs2(n: usize, seed: u64) -> BoxResult<DMatrix<f64>> {
    let mut u = DMatrix::zeros(n, 2);
    for c in 0..2 {
        let s = random_binary(
            n,
            &RandomBinaryOptions {
                seed: 1000 * seed + c as u64 + 17,
                ..Default::default()
            },
        )?;
        for (k, v) in s.iter().enumerate() {
            u[(k, c)] = *v;
        }
    }
    Ok(u)
}

/// Simulates the tank with the stand-in noise at variance-SNR 5:
/// returns (u, y, noise-free y).
pub fn simulate(n: usize, seed: u64) -> BoxResult<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)> {
    let fx = stirred_tank_2_6_2()?;
    let noise = fx
        .noise_spec(5.0, SnrDefinition::Variance, 5000 + seed)
        .ok_or("fixture without noise model")?;
    let sim = fx.simulator()?.with_noise(noise)?;
    let out = sim.simulate(&Excitation::input(rbs2(n, seed)?))?;
    Ok((out.u().clone(), out.y, out.y_clean))
}

/// e_step = max_k |ŷ(k) − y(k)| / max_k |y(k)| over `horizon` samples for the
/// channel (output o, input i) (spec §0).
pub fn step_error(
    model: &StateSpace,
    truth: &StateSpace,
    o: usize,
    i: usize,
    horizon: usize,
) -> BoxResult<f64> {
    let sm = model.step(horizon, None)?;
    let st = truth.step(horizon, None)?;
    let (mut num, mut den): (f64, f64) = (0.0, 0.0);
    for k in 0..horizon {
        num = num.max((sm[i][(k, o)] - st[i][(k, o)]).abs());
        den = den.max(st[i][(k, o)].abs());
    }
    Ok(num / den)
}

/// Median of a slice (NaN-free).
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

///
/// The thesis' route: (A, C) from the state sequences. The library default
/// since 2026-11-25 (shift invariance, consistent for data from an order-n
/// innovations model) does worse here: the Box–Jenkins noise has its own
/// poles (0.97, 0.9, 0.86), so the order-3 truncation of the subspace
/// carries noise modes, and N4SID's median e_step of G₂₂ was 0.117 (MOESP
/// 0.114, CVA 0.058; tolerance 0.05), with unstable estimates on some seeds
/// (max |Ĝ₁₂ step| 2.7e6) and §2.6.1 validation fits 67.6 % / 85.3 %.
/// The state-sequence regression keeps the deterministic dynamics. With
/// it, removing the means (the other default change) moved the N4SID
/// medians G₁₁/G₂₁/G₂₂ 0.146/0.076/0.027 → 0.141/0.069/0.026 and the
/// §2.6.1 fits 85.2/95.6 → 84.8/95.8 % (MOESP alike; CVA G₂₂ 0.021 → 0.023).
fn options(method: Method) -> SubspaceOptions {
    SubspaceOptions {
        method,
        order: OrderSelection::Fixed(3),
        past: 15,
        future: 15,
        feedthrough: Feedthrough::Zero,
        noise_model: false,
        system: SystemEstimate::StateSequence,
        ..Default::default()
    }
}

/// Validation fit 100(1 − ‖ŷ − y₀‖/‖y₀ − mean y₀‖) per output, simulation
/// from zero state, the first `discard` samples dropped (spec §0, A3.1).
pub fn validation_fit(
    model: &StateSpace,
    u: &DMatrix<f64>,
    y0: &DMatrix<f64>,
    discard: usize,
) -> BoxResult<Vec<f64>> {
    let yh = model.lsim(u, None, None)?.y;
    let n = u.nrows();
    let mut fits = Vec::new();
    for o in 0..y0.ncols() {
        let seg = (discard..n).map(|k| y0[(k, o)]);
        let mean = seg.clone().sum::<f64>() / (n - discard) as f64;
        let num: f64 = (discard..n)
            .map(|k| (yh[(k, o)] - y0[(k, o)]).powi(2))
            .sum::<f64>()
            .sqrt();
        let den: f64 = seg.map(|v| (v - mean).powi(2)).sum::<f64>().sqrt();
        fits.push(100.0 * (1.0 - num / den));
    }
    Ok(fits)
}

/// Thesis Figs. 2.11–2.19: step responses of the process and the models
/// estimated by CVA (Figs. 2.11–2.13), N4SID (2.14–2.16) and MOESP
/// (2.17–2.19), on the first seed, over the 300 samples of e_step; one
/// figure per channel (u₁→y₁, u₁→y₂, u₂→y₂) with the three methods.
fn figs_2_11_to_2_19(
    truth: &StateSpace,
    cva: &StateSpace,
    n4sid: &StateSpace,
    moesp: &StateSpace,
) -> BoxResult<Vec<FigureData>> {
    [
        ("2.11, 2.14, 2.17", "2-11-14-17", 0, 0),
        ("2.12, 2.15, 2.18", "2-12-15-18", 1, 0),
        ("2.13, 2.16, 2.19", "2-13-16-19", 1, 1),
    ]
    .into_iter()
    .map(|(figs, id, o, i)| -> BoxResult<FigureData> {
        let mut f = FigureData::new(
            format!("li-figs{id}"),
            format!(
                "Li (2001) Figs. {figs}: step responses of the process from u{} to y{} and the \
                 models estimated by CVA, N4SID and MOESP (§2.6.2 stirred tank, 3000 samples, \
                 var-SNR 5, order 3, seed 0)",
                i + 1,
                o + 1
            ),
            "t (samples)",
            format!("y{} (unit step on u{})", o + 1, i + 1),
        );
        f.curves = step_curves(
            &[
                ("process", truth, CurveStyle::Line),
                ("CVA", cva, CurveStyle::Line),
                ("N4SID", n4sid, CurveStyle::Line),
                ("MOESP", moesp, CurveStyle::Line),
            ],
            o,
            i,
            300,
        )?;
        Ok(f)
    })
    .collect()
}

/// Runs A3.1 and the §2.6.1 stand-in.
pub fn run() -> BoxResult<Reproduction> {
    let mut rep = Reproduction::new(
        "A3.1",
        "Li 2001 §2.6.2: CVA / N4SID / MOESP on the stirred tank (and the §2.6.1 stand-in)",
    );
    let truth = stirred_tank_2_6_2()?.plant;
    let methods = [Method::N4sid, Method::Moesp, Method::Cva];
    // errors[method][channel] over seeds; worst pole error; G12 max step.
    let mut errors = vec![vec![Vec::new(); 3]; 3];
    let mut pole_err = [0.0f64; 3];
    let mut g12 = [0.0f64; 3];
    let mut g12_all = vec![Vec::new(); 3];
    let mut fits = vec![vec![Vec::new(); 2]; 3];
    let mut shown: Vec<StateSpace> = Vec::new();
    for seed in 0..SEEDS {
        let (u, y, _) = simulate(3000, seed)?;
        let (uv, yv, y0v) = simulate(6000, 100 + seed)?;
        let (ue, ye) = (uv.rows(0, 3000).into_owned(), yv.rows(0, 3000).into_owned());
        let (uval, y0val) = (
            uv.rows(3000, 3000).into_owned(),
            y0v.rows(3000, 3000).into_owned(),
        );
        for (mi, &m) in methods.iter().enumerate() {
            let fit = identify(&[Experiment { u: &u, y: &y }], &options(m))?;
            if seed == 0 {
                shown.push(fit.model.clone());
            }
            for (ci, &(o, i)) in [(0, 0), (1, 0), (1, 1)].iter().enumerate() {
                errors[mi][ci].push(step_error(&fit.model, &truth, o, i, 300)?);
            }
            let near = fit
                .model
                .poles()?
                .iter()
                .map(|p| (p - num_complex::Complex64::new(0.9868, 0.0)).norm())
                .fold(f64::INFINITY, f64::min);
            pole_err[mi] = pole_err[mi].max(near);
            let st = fit.model.step(300, None)?;
            let m12 = (0..300).map(|k| st[1][(k, 0)].abs()).fold(0.0, f64::max);
            g12[mi] = g12[mi].max(m12);
            g12_all[mi].push(m12);
            // §2.6.1 stand-in: estimate on the first 3000, validate on the last 3000.
            let est = identify(&[Experiment { u: &ue, y: &ye }], &options(m))?;
            let f = validation_fit(&est.model, &uval, &y0val, 200)?;
            fits[mi][0].push(f[0]);
            fits[mi][1].push(f[1]);
        }
    }
    let names = ["G11", "G21", "G22"];
    // Spec A3.1 acceptance; RI medians 0.13 / 0.14 / 0.023 (var-SNR 5).
    let bounds = [0.20, 0.25, 0.05];
    let reference = [0.13, 0.14, 0.023];
    let mut medians = [[0.0; 3]; 3];
    for (mi, m) in methods.iter().enumerate() {
        for ci in 0..3 {
            let med = median(&errors[mi][ci]);
            medians[mi][ci] = med;
            rep.check(
                Check::below(
                    format!("{} median e_step(300) {}", m.name(), names[ci]),
                    med,
                    bounds[ci],
                )
                .with_note(format!("spec A3.1; RI median {}", reference[ci])),
            );
            let worst = errors[mi][ci].iter().cloned().fold(0.0, f64::max);
            rep.figure(format!("{} worst e_step {}", m.name(), names[ci]), worst);
        }
        rep.check(
            Check::below(
                format!("{} worst |pole − 0.9868| (every seed)", m.name()),
                pole_err[mi],
                0.01,
            )
            .with_note("spec A3.1; RI worst 0.005; nearest pole, never matched by sorting"),
        );
        rep.check(
            Check::below(
                format!("{} max |Ĝ12 step| (all seeds)", m.name()),
                g12[mi],
                0.15 * 10.73,
            )
            .with_note(
                "spec A3.1: < 0.15·(G11 DC gain 10.73); RI median 0.024, worst 0.075 — read, like \
                 the bound, as fractions of 10.73 (the relative figures below); ours are about 1.6x \
                 the RI's",
            ),
        );
        rep.figure(
            format!("{} median |Ĝ12 step| / 10.73 (RI 0.024)", m.name()),
            median(&g12_all[mi]) / 10.73,
        );
        rep.figure(
            format!("{} max |Ĝ12 step| / 10.73 (RI 0.075)", m.name()),
            g12[mi] / 10.73,
        );
        let f1 = median(&fits[mi][0]);
        let f2 = median(&fits[mi][1]);
        rep.check(
            Check::above(
                format!("{} §2.6.1 stand-in median validation fit y1 (%)", m.name()),
                f1,
                80.0,
            )
            .with_note("spec A3.1: ≥ 80%; RI median 88%"),
        );
        rep.check(
            Check::above(
                format!("{} §2.6.1 stand-in median validation fit y2 (%)", m.name()),
                f2,
                90.0,
            )
            .with_note("spec A3.1: ≥ 90%; RI median 95%"),
        );
    }
    if let [n4sid, moesp, cva] = shown.as_slice() {
        for fig in figs_2_11_to_2_19(&truth, cva, n4sid, moesp)? {
            rep.plot(fig);
        }
    }
    for ci in 0..3 {
        let hi = medians.iter().map(|m| m[ci]).fold(0.0, f64::max);
        let lo = medians.iter().map(|m| m[ci]).fold(f64::INFINITY, f64::min);
        rep.check(
            Check::below(
                format!("methods agree: max/min median e_step {}", names[ci]),
                hi / lo,
                2.0,
            )
            .with_note("spec A3.1: the three methods' median errors agree within a factor of 2"),
        );
    }
    Ok(rep)
}
