//! Li (2001) thesis §7.8.2, second example (spec A3.9, multirate part):
//! the simulated stirred tank with y₁ sampled every 5 and y₂ every 1, a PI
//! loop u₂ → y₂ with RBS set-point dither f, y₁ open loop with RBS u₁,
//! coloured disturbance, 5000 samples, order 3.
//!
//! Two-step route (erratum L-18): lifted IV identification with lifted
//! instruments [u₁; f] (time-major interleaving as in §7.5, α = 6,
//! α_p = 2α, L-16) and the causal D̄, then the principal 5th root and LS
//! for B. The one-step formula (7.27) must report the rank deficiency of
//! Γ_R, because the 0.9868 mode is seen only in y₁.
//!
//! SNR: **std-SNR 5**, std(noise-free y_i)/std(v_i) = 5 per output (the
//! spec's acceptance for this section is calibrated under the std reading).

use lifted_lti::StateSpace;
use lifted_multirate::{
    Error as MrError, LiftedIvOptions, MultirateLifting, Ordering, identify_lifted_iv,
    identify_one_step_iv,
};
use lifted_subspace::{MultirateIvOptions, OrderSelection};
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::a3_lifting::{median, randn, std_dev, step_errors};
use crate::{Check, Reproduction};

type BoxResult<T> = Result<T, Box<dyn std::error::Error>>;

/// The §7.8.2 plant (lifted-sim reference fixture; L-14: G₁₂ = 0, 0.913).
fn plant() -> BoxResult<StateSpace> {
    Ok(lifted_sim::plants::stirred_tank_7_8_2()?.plant)
}

struct Record {
    u: DMatrix<f64>,
    f: DMatrix<f64>,
    y: DMatrix<f64>,
}

/// Closed-loop simulation; `snr = None` is noise free.
fn simulate(len: usize, snr: Option<f64>, rng: &mut ChaCha8Rng) -> Record {
    let sign = |x: f64| if x >= 0.0 { 1.0 } else { -1.0 };
    let u1: Vec<f64> = (0..len).map(|_| sign(randn(rng))).collect();
    let f: Vec<f64> = (0..len).map(|_| sign(randn(rng))).collect();
    let e: Vec<(f64, f64)> = (0..len).map(|_| (randn(rng), randn(rng))).collect();
    // disturbance v₁ = 0.11/(1−0.97q⁻¹) e₁, v₂ = −0.02/(1−0.9q⁻¹) e₁ + 0.04/(1−0.86q⁻¹) e₂
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    let mut v = Vec::with_capacity(len);
    for &(e1, e2) in &e {
        a = 0.97 * a + 0.11 * e1;
        b = 0.9 * b - 0.02 * e1;
        c = 0.86 * c + 0.04 * e2;
        v.push((a, b + c));
    }
    let run = |s1: f64, s2: f64| {
        let (mut x11, mut x21, mut x22, mut integ) = (0.0, 0.0, 0.0, 0.0);
        let mut u = DMatrix::zeros(len, 2);
        let mut y = DMatrix::zeros(len, 2);
        let mut yd = DMatrix::zeros(len, 2);
        for k in 0..len {
            yd[(k, 0)] = x11;
            yd[(k, 1)] = x21 + x22;
            y[(k, 0)] = x11 + s1 * v[k].0;
            y[(k, 1)] = x21 + x22 + s2 * v[k].1;
            let err = f[k] - y[(k, 1)];
            integ += 0.1 * err;
            let u2 = 1.5 * err + integ;
            u[(k, 0)] = u1[k];
            u[(k, 1)] = u2;
            x11 = 0.9868 * x11 + 0.1416 * u1[k];
            x21 = 0.913 * x21 - 0.0379 * u1[k];
            x22 = 0.9048 * x22 + 0.0595 * u2;
        }
        (u, y, yd)
    };
    let (u, y) = match snr {
        None => {
            let (u, y, _) = run(0.0, 0.0);
            (u, y)
        }
        Some(snr) => {
            let (_, _, yd) = run(1.0, 1.0);
            let col =
                |m: &DMatrix<f64>, c: usize| m.column(c).iter().cloned().collect::<Vec<f64>>();
            let v1: Vec<f64> = v.iter().map(|x| x.0).collect();
            let v2: Vec<f64> = v.iter().map(|x| x.1).collect();
            let s1 = std_dev(&col(&yd, 0)) / std_dev(&v1) / snr;
            let s2 = std_dev(&col(&yd, 1)) / std_dev(&v2) / snr;
            let (u, y, _) = run(s1, s2);
            (u, y)
        }
    };
    let fm = DMatrix::from_fn(len, 2, |k, c| if c == 0 { u1[k] } else { f[k] });
    Record { u, f: fm, y }
}

fn two_step(rec: &Record) -> Result<StateSpace, MrError> {
    let lifting = MultirateLifting::mimo(2, &[5, 1], Ordering::TimeMajor)?;
    let ds = lifting.dataset(1.0, rec.u.clone(), rec.y.clone())?;
    let opts = LiftedIvOptions {
        order: OrderSelection::Fixed(3),
        alpha: 6,
        alpha_p: Some(12),
        ..Default::default()
    };
    Ok(identify_lifted_iv(&ds, &rec.f, Ordering::TimeMajor, &opts)?.fast)
}

/// A3.9 multirate stirred tank.
pub fn run() -> BoxResult<Reproduction> {
    let mut rep = Reproduction::new("A3.9b", "§7.8.2 multirate stirred tank: two-step lifted IV");
    let truth = plant()?;
    // noise free
    let mut rng = ChaCha8Rng::seed_from_u64(7820);
    let rec = simulate(5000, None, &mut rng);
    let g = two_step(&rec)?;
    let e = step_errors(&g, &truth, 300)?;
    let worst_nf = e[(0, 0)].max(e[(1, 0)]).max(e[(1, 1)]);
    rep.check(
        Check::below(
            "noise free: worst e_step(300) over G11, G21, G22",
            worst_nf,
            0.01,
        )
        .with_note("spec A3.9: < 0.01 (RI ≤ 0.004)"),
    );
    // one-step route must report the rank deficiency of Γ_R (L-18)
    let lifting = MultirateLifting::mimo(2, &[5, 1], Ordering::TimeMajor)?;
    let ds = lifting.dataset(1.0, rec.u.clone(), rec.y.clone())?;
    let one = identify_one_step_iv(
        &ds,
        &rec.f,
        &MultirateIvOptions {
            order: OrderSelection::Fixed(3),
            alpha: 6,
            ..Default::default()
        },
    );
    let rank_def = matches!(
        one,
        Err(MrError::Subspace(
            lifted_subspace::Error::RankDeficient { .. }
        ))
    );
    rep.check(Check::holds(
        "one-step (7.27) reports a rank-deficient Γ_R",
        format!("{:?}", one.as_ref().err()),
        rank_def,
    ));
    // std-SNR 5, 8 seeds
    let mut errs = Vec::new();
    let mut unstable = 0;
    let mut other = Vec::new();
    for seed in 0..8u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(7821 + seed);
        let rec = simulate(5000, Some(5.0), &mut rng);
        match two_step(&rec) {
            Ok(g) => errs.push(step_errors(&g, &truth, 300)?),
            Err(MrError::Unstable { .. }) => unstable += 1,
            Err(e) => other.push(format!("seed {seed}: {e}")),
        }
    }
    rep.check(Check::holds(
        "no failure other than a reported instability",
        other.join("; "),
        other.is_empty(),
    ));
    rep.check(
        Check::above(
            "stable seeds (of 8); unstable ones are returned as Error::Unstable",
            (8 - unstable - other.len()) as f64,
            6.5,
        )
        .with_note("spec A3.9: at least 7 of 8 (RI: one seed had lifted pole 1.047)"),
    );
    let med = |i: usize, j: usize| median(&errs.iter().map(|e| e[(i, j)]).collect::<Vec<_>>());
    for (name, i, j, bound, ri) in [
        ("G11", 0, 0, 0.15, "0.08"),
        ("G21", 1, 0, 0.25, "0.14"),
        ("G22", 1, 1, 0.08, "0.03"),
    ] {
        rep.check(
            Check::below(
                format!("std-SNR 5: median e_step(300) {name}"),
                med(i, j),
                bound,
            )
            .with_note(format!("spec A3.9; RI median {ri}")),
        );
    }
    Ok(rep)
}
