//! Spec A3.10: thesis Chapter 8 — DMC / state-space GPC and dual-rate
//! inferential MPC, and the §8.3 stirred-tank stand-in.
//!
//! (a)–(e) follow the spec's corrected formulas (erratum L-19): +y(nk) in
//! (8.4), a_lΔu(nk) in the inter-sample estimate, C_IA_I^{j−i}B_I paired with
//! Δu(nk+i−1). Models: P_T = (0.1q⁻¹ + 0.05q⁻²)/(1 − 1.2q⁻¹ + 0.35q⁻²)
//! (`spec/verify/dmc.py`) plus seeded random stable second-order models.
//! The open-loop records of (a)–(c) come from lifted-sim (`Simulator` on the
//! model, y = P_T u + v): Gaussian white input σ = 1 (lifted-prbs
//! `gaussian_white`) and the integrated white disturbance of the model (8.1),
//! v(k) = v(k−1) + e(k) with e ~ N(0, 0.05²) (`NoiseSpec { integrated: true,
//! .. }` at an absolute level); fixed seeds. The closed loops of (d), (e)
//! and the tank (the MPC law computing u from the measurements every step)
//! are `lifted_mpc::simulate`.
//!
//! Numbers obtained: (a) 2.0e-15 (printed sign of (8.4) off by ≥ 0.356,
//! printed inter-sample form by ≥ 0.154), (b) 9.4e-16, (c) 2.2e-15, (d)
//! 6.7e-16 / 7.8e-16, (e) 0.
//!
//! §8.3 stand-in: the A3.7 fast stirred-tank model
//! (`lifted_sim::plants::stirred_tank_5_3_1`), y₁ (level) sampled every 10,
//! y₂ every sample, horizons 12/3, Q = R = I, set-point steps and a level
//! disturbance step. The inferential MPC runs twice: on the true fast model,
//! and on a fast model identified by `lifted-multirate` (lifted N4SID, order
//! 4, principal 10th root) from 10 000 multirate samples simulated by
//! lifted-sim (the fixture in open loop, sampling (10, 0) and (1, 0)): two
//! RBS ±1 inputs (lifted-prbs), the fixture's coloured noise model scaled
//! per output to var-SNR 5 after it is generated (spec §0,
//! `SnrDefinition::Variance`). Numbers (seed 830): IAE ratio inferential /
//! slow 0.402 (true model), 0.497 (identified model; 0.49–0.72 over seeds
//! 830–844), offset 2.9e-9 (true) and 4.1e-5 (identified; ≤ 6.2e-5 over
//! seeds 830–844).

use lifted_lti::{StateSpace, TransferFunction};
use lifted_mpc::{
    Dmc, LoopSetup, MoveLaw, MpcOptions, SlowRate, StateSpaceMpc, hold_model, integrated_model,
    simulate, step_coefficients,
};
use lifted_multirate::{LiftedIdOptions, Ordering, ProcedureOptions, identify_multirate};
use lifted_prbs::{GaussianOptions, gaussian_white};
use lifted_sim::plants::stirred_tank_5_3_1;
use lifted_sim::{Excitation, NoiseLevel, NoiseSpec, Plant, SimOutput, Simulator, SnrDefinition};
use lifted_subspace::OrderSelection;
use lifted_subspace::SystemEstimate;
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::a3_subspace::rbs2;
use crate::{Check, Reproduction};

type BoxResult<T> = Result<T, Box<dyn std::error::Error>>;

fn tf(num: &[f64], den: &[f64]) -> BoxResult<StateSpace> {
    Ok(TransferFunction::from_coeffs(num, den, Some(1.0))?.to_ss()?)
}

/// The dmc.py model and `extra` seeded random stable second-order models
/// (real poles in (−0.9, 0.9), numerator b₁z + b₂ with b ∈ (−1, 1)).
pub fn test_models(extra: usize) -> BoxResult<Vec<StateSpace>> {
    let mut out = vec![tf(&[0.1, 0.05], &[1.0, -1.2, 0.35])?];
    let mut rng = ChaCha8Rng::seed_from_u64(810);
    for _ in 0..extra {
        let p1 = rng.random::<f64>() * 1.8 - 0.9;
        let p2 = rng.random::<f64>() * 1.8 - 0.9;
        let b1 = rng.random::<f64>() * 2.0 - 1.0;
        let b2 = rng.random::<f64>() * 2.0 - 1.0;
        out.push(tf(&[b1, b2], &[1.0, -(p1 + p2), p1 * p2])?);
    }
    Ok(out)
}

/// Standard deviation of the white source of the integrated output
/// disturbance in the identity checks (a)–(c).
const IDENTITY_NOISE_STD: f64 = 0.05;

/// Open-loop record of the model (8.1) with lifted-sim: Gaussian white input
/// u (σ = 1, lifted-prbs, seed `seed`), y = P_T u + v with the integrated
/// white disturbance v(k) = v(k−1) + e(k), e ~ N(0, 0.05²) (`NoiseSpec`
/// with `integrated: true`, seed `seed + 1`). `y_clean` is P_T u.
fn identity_record(model: &StateSpace, len: usize, seed: u64) -> BoxResult<SimOutput> {
    let u = gaussian_white(
        len,
        &GaussianOptions {
            std: 1.0,
            hold: 1,
            seed,
        },
    )?;
    let sim = Simulator::open_loop(Plant::discrete(model, &[], &[])?).with_noise(NoiseSpec {
        integrated: true,
        level: NoiseLevel::Std(vec![IDENTITY_NOISE_STD]),
        seed: seed + 1,
        ..Default::default()
    })?;
    Ok(sim.simulate(&Excitation::input(DMatrix::from_vec(len, 1, u)))?)
}

/// Identity checks (a)–(c) on one SISO model; returns
/// (err_a, printed-sign gap, err_intersample, printed-intersample gap, err_b, err_c).
fn identities(model: &StateSpace, seed: u64) -> BoxResult<[f64; 6]> {
    let (n_slow, k_slow, hp) = (3usize, 50usize, 5usize);
    let nk = n_slow * k_slow;
    let len = nk + hp + 1;
    let rec = identity_record(model, len, seed)?;
    let (u, yd) = (rec.u(), &rec.y_clean);
    let y: Vec<f64> = rec.y.column(0).iter().copied().collect();
    let du = |t: usize| -> f64 { u[(t, 0)] - if t == 0 { 0.0 } else { u[(t - 1, 0)] } };
    let opts = MpcOptions {
        prediction_horizon: hp,
        control_horizon: hp,
        ..MpcOptions::default()
    };
    let dmc = Dmc::new(model, 400, &opts)?;
    let past: Vec<DVector<f64>> = (1..=nk)
        .map(|i| DVector::from_element(1, du(nk - i)))
        .collect();
    let future = DVector::from_fn(hp, |i, _| du(nk + i));
    let ynk = DVector::from_element(1, y[nk]);
    let pred = dmc.predict(&ynk, &past, &future)?;
    let mut err_a: f64 = 0.0;
    let mut gap_printed = f64::INFINITY;
    for j in 1..=hp {
        let truth = y[nk] + yd[(nk + j, 0)] - yd[(nk, 0)];
        let printed = -y[nk] + yd[(nk + j, 0)] - yd[(nk, 0)];
        err_a = err_a.max((pred[j - 1] - truth).abs());
        gap_printed = gap_printed.min((pred[j - 1] - printed).abs());
    }
    // inter-sample estimate (L-19): a_l Δu(nk) … a_1 Δu(nk+l−1)
    let mut err_is: f64 = 0.0;
    let mut gap_is = f64::INFINITY;
    let a = step_coefficients(model, 400)?;
    for l in 1..n_slow {
        let since: Vec<DVector<f64>> = (0..l)
            .map(|i| DVector::from_element(1, du(nk + i)))
            .collect();
        let est = dmc.intersample_estimate(&ynk, &past, &since)?[0];
        let truth = y[nk] + yd[(nk + l, 0)] - yd[(nk, 0)];
        err_is = err_is.max((est - truth).abs());
        // printed form: a_l Δu(nk+1) + … + a_1 Δu(nk+l) (shifted by one sample)
        let mut printed = y[nk];
        for i in 1..=nk {
            printed += (a[i + l][(0, 0)] - a[i][(0, 0)]) * du(nk - i);
        }
        for (i, ai) in a.iter().enumerate().take(l + 1).skip(1) {
            printed += ai[(0, 0)] * du(nk + l + 1 - i);
        }
        gap_is = gap_is.min((printed - truth).abs());
    }
    // (b) K_c against an independent QR least-squares solution of (8.9),
    // random positive weights
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let qw = 0.5 + rng.random::<f64>();
    let rw = 0.1 + rng.random::<f64>();
    let opts_b = MpcOptions {
        prediction_horizon: 12,
        control_horizon: 3,
        output_weight: Some(DMatrix::from_element(1, 1, qw)),
        move_weight: Some(DMatrix::from_element(1, 1, rw)),
        ..MpcOptions::default()
    };
    let law = MoveLaw::new(&step_coefficients(model, 12)?, &opts_b)?;
    let dyn_m = law.dynamic_matrix();
    let (h, m) = dyn_m.shape();
    let mut s = DMatrix::zeros(h + m, m);
    s.rows_mut(0, h).copy_from(&(dyn_m * qw.sqrt()));
    s.rows_mut(h, m)
        .copy_from(&(DMatrix::<f64>::identity(m, m) * rw.sqrt()));
    let mut rhs = DMatrix::zeros(h + m, h);
    rhs.rows_mut(0, h)
        .copy_from(&(DMatrix::<f64>::identity(h, h) * qw.sqrt()));
    let kc_ls = lifted_linalg::lstsq(&s, &rhs)?;
    let err_b = (law.gain() - &kc_ls).amax() / kc_ls.amax().max(1.0);
    // (c) state-space prediction (8.14) against the polynomial one
    let ss = StateSpaceMpc::new(model, &opts)?;
    // x_d(nk) of (8.10)–(8.11): the controller's internal model state,
    // driven by the past moves Δu (part of the MPC algorithm, not a plant
    // simulation)
    let (ai, bi, _) = integrated_model(model)?;
    let mut xd = DVector::zeros(ai.nrows());
    for t in 0..nk {
        xd = &ai * xd + &bi * DVector::from_element(1, du(t));
    }
    let pred_ss = ss.predict(&xd, &ynk, &future)?;
    let err_c = (&pred_ss - &pred).amax();
    Ok([err_a, gap_printed, err_is, gap_is, err_b, err_c])
}

fn steps_reference(len: usize, p: usize, changes: &[(usize, usize, f64)]) -> DMatrix<f64> {
    let mut r = DMatrix::zeros(len, p);
    for &(t0, ch, v) in changes {
        for t in t0..len {
            r[(t, ch)] = v;
        }
    }
    r
}

/// A3.10 (a)–(e).
pub fn run() -> BoxResult<Reproduction> {
    let mut rep = Reproduction::new(
        "A3.10",
        "Li 2001 Ch. 8: DMC / GPC and dual-rate inferential MPC",
    );
    let models = test_models(5)?;
    let mut worst = [0.0f64; 6];
    worst[1] = f64::INFINITY;
    worst[3] = f64::INFINITY;
    for (i, m) in models.iter().enumerate() {
        let r = identities(m, 100 + i as u64)?;
        for k in [0, 2, 4, 5] {
            worst[k] = worst[k].max(r[k]);
        }
        for k in [1, 3] {
            worst[k] = worst[k].min(r[k]);
        }
    }
    rep.check(
        Check::below(
            "(a) max |DMC prediction − (y(nk) + P_T u(nk+j) − P_T u(nk))|, 6 models, j ≤ 5",
            worst[0],
            1e-10,
        )
        .with_note("spec A3.10(a): free + forced prediction with +y(nk) (L-19), N = 400 ≥ nk"),
    );
    rep.check(
        Check::above(
            "(a) printed sign of (8.4) fails: min |prediction − printed form|",
            worst[1],
            1e-6,
        )
        .with_note("the printed −y(nk) differs by 2|y(nk)|"),
    );
    rep.check(Check::below(
        "(a) inter-sample estimate with a_lΔu(nk) (L-19) matches the model, l = 1, 2",
        worst[2],
        1e-10,
    ));
    rep.check(Check::above(
        "(a) printed inter-sample form a_lΔu(nk+1) fails: min gap",
        worst[3],
        1e-6,
    ));
    rep.check(
        Check::below(
            "(b) K_c vs QR least squares of (8.9) (relative max abs)",
            worst[4],
            1e-10,
        )
        .with_note("h = 12, m = 3, random positive Q, R; LS by lifted-linalg lstsq (QR)"),
    );
    rep.check(Check::below(
        "(c) polynomial (8.8) vs state-space (8.14) predictions",
        worst[5],
        1e-10,
    ));

    // (d) dual-rate inferential loop vs fast loop, perfect model, no disturbance
    let model = &models[0];
    let opts = MpcOptions::default();
    let r = steps_reference(300, 1, &[(0, 0, 1.0), (120, 0, -0.5)]);
    let fast = LoopSetup::new(r.clone(), vec![1]);
    let dual = LoopSetup::new(r.clone(), vec![3]);
    let y_fast = simulate(model, &mut StateSpaceMpc::new(model, &opts)?, &fast)?.y;
    let y_dual = simulate(model, &mut StateSpaceMpc::new(model, &opts)?, &dual)?.y;
    let d_ss = (&y_fast - &y_dual).amax();
    let y_fast_dmc = simulate(model, &mut Dmc::new(model, 400, &opts)?, &fast)?.y;
    let y_dual_dmc = simulate(model, &mut Dmc::new(model, 400, &opts)?, &dual)?.y;
    let d_dmc = (&y_fast_dmc - &y_dual_dmc).amax();
    rep.check(
        Check::below(
            "(d) state-space MPC: max |y_dual(n=3) − y_fast|",
            d_ss,
            1e-12,
        )
        .with_note("P̂ = P, no disturbance, set-point steps, 300 samples"),
    );
    rep.check(
        Check::below("(d) DMC: max |y_dual(n=3) − y_fast|", d_dmc, 1e-12)
            .with_note("truncation N = 400 ≥ run length, so the estimate is exact"),
    );
    rep.check(Check::below(
        "(c) DMC and state-space loops coincide (fast)",
        (&y_fast - &y_fast_dmc).amax(),
        1e-10,
    ));

    // (e) bias-corrected inferential DMC is offset-free
    let n = 3;
    let slow = 240;
    let len = n * slow;
    let r = steps_reference(len, 1, &[(0, 0, 1.0), (150, 0, -0.5)]);
    let mut setup = LoopSetup::new(r, vec![n]);
    setup.output_disturbance = Some(DMatrix::from_fn(
        len,
        1,
        |t, _| if t >= 300 { 0.3 } else { 0.0 },
    ));
    let run = simulate(model, &mut Dmc::new(model, 200, &opts)?, &setup)?;
    let off = (200..slow)
        .map(|k| (run.y[(n * k, 0)] + 0.5).abs())
        .fold(0.0, f64::max);
    rep.check(
        Check::below(
            "(e) max |y(nk) − r| for k ≥ 200 (DMC, n = 3, output step 0.3)",
            off,
            1e-6,
        )
        .with_note(
            "perfect model, truncation N = 200, set-point steps at 0 and 150, disturbance at 300",
        ),
    );
    Ok(rep)
}

/// Fast tank model identified from multirate data: lifted-sim's §5.3.1
/// fixture in open loop with y₁ sampled every `n` and y₂ every sample, two
/// RBS ±1 inputs from lifted-prbs (`a3_subspace::rbs2`), the fixture's 2×2
/// coloured noise scaled per output to var-SNR 5 after it is generated (spec
/// §0, `SnrDefinition::Variance`); lifted N4SID order 4, 6 block rows.
pub fn identify_tank(n: usize, len: usize, seed: u64) -> BoxResult<StateSpace> {
    let fx = stirred_tank_5_3_1()?;
    let noise = fx
        .noise_spec(5.0, SnrDefinition::Variance, seed)
        .ok_or("the §5.3.1 fixture has a noise model")?;
    let sim = Simulator::open_loop(fx.discrete_plant()?)
        .with_sampling(&[(n, 0), (1, 0)])?
        .with_noise(noise)?;
    let out = sim.simulate(&Excitation::input(rbs2(len, seed)?))?;
    // The thesis' route (state-sequence N4SID on the lifted data). With the
    // library's consistent default (shift invariance, since 2026-11-25) this
    // short record (1000 lifted samples, var-SNR 5) gives a worse model for
    // the controller: IAE ratio 0.743 (was 0.497) and end offset 1.15e-3
    // (was 4.1e-5) for seed 830, so the reproduction keeps the thesis route
    // (with the means removed: IAE ratio 0.494, offset 2.9e-5).
    let opts = ProcedureOptions {
        identification: LiftedIdOptions {
            order: OrderSelection::Fixed(4),
            past: 6,
            future: 6,
            system: SystemEstimate::StateSequence,
            ..Default::default()
        },
        ordering: Ordering::TimeMajor,
        ..Default::default()
    };
    Ok(identify_multirate(&out.data, None, &opts)?.fast)
}

/// §8.3 stand-in: fast MPC (every sample), inferential MPC (level every 10,
/// true fast model), slow single-rate MPC at 10T on the held model.
pub fn run_tank() -> BoxResult<Reproduction> {
    let mut rep = Reproduction::new(
        "A3.10 §8.3",
        "Stirred tank stand-in: inferential MPC, level every 10 T, horizons 12/3, Q = R = I",
    );
    let plant = stirred_tank_5_3_1()?.plant;
    let n = 10;
    let len = 1200;
    let r = steps_reference(len, 2, &[(0, 0, 1.0), (300, 1, 0.5), (600, 0, 0.0)]);
    let mut setup = LoopSetup::new(r, vec![n, 1]);
    setup.output_disturbance = Some(DMatrix::from_fn(len, 2, |t, c| {
        if c == 0 && t >= 900 { 0.2 } else { 0.0 }
    }));
    let opts = MpcOptions::default();
    let mut fast_setup = setup.clone();
    fast_setup.periods = vec![1, 1];
    let fast = simulate(&plant, &mut StateSpaceMpc::new(&plant, &opts)?, &fast_setup)?;
    let inf = simulate(&plant, &mut StateSpaceMpc::new(&plant, &opts)?, &setup)?;
    let slow_model = hold_model(&plant, n)?;
    let mut slow_ctrl = SlowRate::new(StateSpaceMpc::new(&slow_model, &opts)?, n)?;
    let slow = simulate(&plant, &mut slow_ctrl, &setup)?;
    let identified = identify_tank(n, 10_000, 830)?;
    let dc_true = plant.dc_gain()?;
    let dc_id = identified.dc_gain()?;
    for (i, j) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
        rep.figure(
            format!(
                "identified DC gain G{}{} (true {:.4})",
                i + 1,
                j + 1,
                dc_true[(i, j)]
            ),
            dc_id[(i, j)],
        );
    }
    let inf_id = simulate(&plant, &mut StateSpaceMpc::new(&identified, &opts)?, &setup)?;
    for (name, run) in [
        ("fast MPC (all samples)", &fast),
        ("inferential MPC (true model)", &inf),
        ("inferential MPC (identified model)", &inf_id),
        ("slow MPC at 10T", &slow),
    ] {
        let p = &run.performance;
        rep.figure(format!("{name}: IAE y1"), p.iae[0]);
        rep.figure(format!("{name}: IAE y2"), p.iae[1]);
        rep.figure(format!("{name}: overshoot y1"), p.overshoot[0]);
        rep.figure(format!("{name}: overshoot y2"), p.overshoot[1]);
        rep.figure(
            format!("{name}: settling y1 (samples, -1 = not settled)"),
            p.settling_time[0].map_or(-1.0, |s| s as f64),
        );
        rep.figure(format!("{name}: input energy"), p.input_energy);
    }
    let last = len - 1;
    let off = ((inf.y[(last, 0)] - 0.0).abs()).max((inf.y[(last, 1)] - 0.5).abs());
    rep.check(
        Check::below("inferential MPC offset-free: max |y(end) − r|", off, 1e-6)
            .with_note("level disturbance step 0.2 at t = 900, 300 samples to settle"),
    );
    let peak = inf.y.amax();
    rep.check(
        Check::below("inferential MPC bounded: max |y|", peak, 10.0)
            .with_note("closed-loop stability (perfect model, linear loop)"),
    );
    let iae_inf = inf.performance.iae[0] + inf.performance.iae[1];
    let iae_slow = slow.performance.iae[0] + slow.performance.iae[1];
    rep.check(
        Check::below(
            "IAE inferential (true model) / IAE slow single-rate (sum over outputs)",
            iae_inf / iae_slow,
            1.0,
        )
        .with_note("slow MPC: same horizons 12/3 in slow samples on the held model (A¹⁰, ΣAⁱB, C)"),
    );
    let iae_id = inf_id.performance.iae[0] + inf_id.performance.iae[1];
    rep.check(
        Check::below("IAE inferential (identified model) / IAE slow single-rate", iae_id / iae_slow, 1.0).with_note(
            "fast model from lifted-multirate identify_multirate (one seed, var-SNR 5); not calibrated: first value obtained",
        ),
    );
    let off_id = (inf_id.y[(last, 0)].abs()).max((inf_id.y[(last, 1)] - 0.5).abs());
    rep.check(
        Check::below(
            "inferential MPC on the identified model offset-free: max |y(end) − r|",
            off_id,
            1e-3,
        )
        .with_note("bias correction (8.13) removes the model-plant mismatch offset"),
    );
    rep.check(Check::below(
        "(d) on the tank: inferential equals fast without disturbance before t = 900",
        (inf.y.rows(0, 900) - fast.y.rows(0, 900)).amax(),
        1e-10,
    ));
    Ok(rep)
}
