//! Spec A3.9 (thesis §7.8.2, first example): closed-loop instrumental-variable
//! subspace identification of the SISO loop, compared with plain N4SID on the
//! same data; and the negative test of the one-step multirate formula (7.27).
//!
//! Set-up (spec A3.9): P(z) = 0.09063z⁻²/(1 − 0.81873z⁻¹) (0.5e^{−s}/(5s+1),
//! T = 1), controller 0.25/(1 − z⁻¹), disturbance N = 0.28347z⁻¹/(1 −
//! 0.71653z⁻¹) (ZOH of 1/(3s+1)) driven by white e (`lifted_sim::plants::
//! chapter7_siso`); RBS ±1 added to the control signal (plant-input dither f),
//! set-point 0; 3000 samples; SNR 2.5 with the spec §0 definition
//! var(noise-free output)/var(noise) (the simulator scales the noise after a
//! noise-free run of the loop); α = 8, α_p = 16 (erratum L-16); order 2;
//! 20 seeds, medians.
//!
//! [`run_bias`] is a second, clearly separate experiment (issue 7, not a
//! spec check): the same loop in a noise-dominated regime fixed a priori
//! (var-SNR 0.5, N = 3000 and 12 000), where plain N4SID's closed-loop bias
//! shows and the IV estimate is closer.
//!
//! Default change 2026-11-25: the plain N4SID of [`run_bias`] now uses
//! shift invariance with the means removed; IV minus plain N4SID (var-SNR
//! 0.5) moved from −0.102 / −0.051 / −0.080 to −0.155 / −0.078 / −0.039
//! (e_step, |DC − 0.5|, |pole − 0.8187| at N = 3000) and from −0.095 /
//! −0.048 / −0.096 to −0.137 / −0.069 / −0.051 at N = 12 000; plain N4SID's
//! 12 000/3000 ratios 1.043 / 1.025 → 0.988 / 0.981 (it stays biased in
//! closed loop, as it should).

use lifted_lti::StateSpace;
use lifted_prbs::{RandomBinaryOptions, random_binary};
use lifted_sim::plants::{chapter7_siso, stirred_tank_7_8_2};
use lifted_sim::{Excitation, SnrDefinition};
use lifted_subspace::{
    Error as SubspaceError, Experiment, Feedthrough, IvExperiment, IvOptions, MultirateIvOptions,
    OrderSelection, SubspaceOptions, identify, iv_identify, iv_multirate_fast,
};
use nalgebra::DMatrix;

use crate::a3_subspace::{median, step_error};
use crate::report::{CurveStyle, FigureData, step_curves};
use crate::{Check, Reproduction};

type BoxErr = Box<dyn std::error::Error>;
type BoxResult<T> = Result<T, BoxErr>;

/// Number of seeds (spec A3.9: 20).
pub const SEEDS: u64 = 20;

fn rbs(n: usize, seed: u64) -> BoxResult<DMatrix<f64>> {
    let s = random_binary(
        n,
        &RandomBinaryOptions {
            seed,
            ..Default::default()
        },
    )?;
    Ok(DMatrix::from_column_slice(n, 1, &s))
}

/// The IV method of spec A3.9: order 2, α = 8, α_p = 16 (erratum L-16).
fn iv_options() -> IvOptions {
    IvOptions {
        order: OrderSelection::Fixed(2),
        alpha: 8,
        alpha_p: Some(16),
        ..Default::default()
    }
}

/// Plain N4SID on the same data: order 2, p = f = 8, free D.
fn n4sid_options() -> SubspaceOptions {
    SubspaceOptions {
        order: OrderSelection::Fixed(2),
        past: 8,
        future: 8,
        feedthrough: Feedthrough::Free,
        noise_model: false,
        ..Default::default()
    }
}

/// (e_step(60), |DC − 0.5|, |dominant pole − 0.81873|, |second pole|).
fn metrics(model: &StateSpace, truth: &StateSpace) -> BoxResult<[f64; 4]> {
    let e = step_error(model, truth, 0, 0, 60)?;
    let dc = (model.dc_gain()?[(0, 0)] - 0.5).abs();
    let mut p: Vec<f64> = model.poles()?.iter().map(|z| z.norm()).collect();
    p.sort_by(|a, b| b.total_cmp(a));
    let dom = model
        .poles()?
        .iter()
        .map(|z| (z - num_complex::Complex64::new(0.81873, 0.0)).norm())
        .fold(f64::INFINITY, f64::min);
    Ok([e, dc, dom, p.get(1).cloned().unwrap_or(0.0)])
}

/// Thesis Fig. 7.12: step responses of the true process and of the
/// closed-loop IV estimate (past dither as instrument) over the 60 samples
/// of e_step, first seed; the §7.3 IV with u as its own instrument on the
/// same closed-loop data for comparison.
fn fig_7_12(
    truth: &StateSpace,
    f_iv: &StateSpace,
    u_iv: &StateSpace,
    seed: u64,
) -> BoxResult<FigureData> {
    let mut f = FigureData::new(
        "li-fig7-12",
        format!(
            "Li (2001) Fig. 7.12: step response of the true system 0.5e^{{−s}}/(5s+1) and the \
             system estimated by the closed-loop IV subspace method (§7.8.2 SISO, var-SNR 2.5, \
             3000 samples, seed {seed}); the open-loop IV (u as instrument) on the same data"
        ),
        "t [s] (T = 1)",
        "y",
    );
    f.curves = step_curves(
        &[
            ("true system", truth, CurveStyle::Line),
            ("IV, past dither f as instrument", f_iv, CurveStyle::Points),
            ("IV, u as instrument", u_iv, CurveStyle::Line),
        ],
        0,
        0,
        60,
    )?;
    Ok(f)
}

/// Runs the SISO closed-loop experiment and the (7.27) negative test.
pub fn run() -> BoxResult<Reproduction> {
    let mut rep = Reproduction::new(
        "A3.9",
        "Li 2001 §7.8.2: closed-loop IV subspace identification (SISO) and the one-step multirate formula",
    );
    let fx = chapter7_siso()?;
    let truth = fx.discrete_plant()?.model().clone();
    let mut iv = vec![Vec::new(); 4];
    let mut n4 = vec![Vec::new(); 4];
    let mut ivu = vec![Vec::new(); 4];
    let mut shown = None;
    for seed in 0..SEEDS {
        let noise = fx
            .noise_spec(2.5, SnrDefinition::Variance, 700 + seed)
            .ok_or("fixture without noise model")?;
        let sim = fx.simulator()?.with_noise(noise)?;
        let f = rbs(3000, 300 + seed)?;
        let out = sim.simulate(&Excitation::input(f.clone()))?;
        let (u, y) = (out.u().clone(), out.y.clone());
        let opts = iv_options();
        let m = iv_identify(
            &[IvExperiment {
                u: &u,
                y: &y,
                instrument: Some(&f),
            }],
            &opts,
        )?;
        for (k, v) in metrics(&m.model, &truth)?.iter().enumerate() {
            iv[k].push(*v);
        }
        // The open-loop IV method of §7.3 (u as its own instrument) on the
        // same closed-loop data: u is correlated with the noise.
        let mu = iv_identify(
            &[IvExperiment {
                u: &u,
                y: &y,
                instrument: None,
            }],
            &opts,
        )?;
        for (k, v) in metrics(&mu.model, &truth)?.iter().enumerate() {
            ivu[k].push(*v);
        }
        if shown.is_none() {
            shown = Some((seed, m.model.clone(), mu.model.clone()));
        }
        let plain = identify(&[Experiment { u: &u, y: &y }], &n4sid_options())?;
        for (k, v) in metrics(&plain.model, &truth)?.iter().enumerate() {
            n4[k].push(*v);
        }
    }
    let med = |v: &Vec<f64>| median(v);
    rep.check(
        Check::below("IV median e_step(60)", med(&iv[0]), 0.12).with_note("spec A3.9; RI 0.082"),
    );
    rep.check(
        Check::below("IV median |DC − 0.5|", med(&iv[1]), 0.06).with_note("spec A3.9; RI 0.039"),
    );
    rep.check(
        Check::below("IV median |pole − 0.8187|", med(&iv[2]), 0.035)
            .with_note("spec A3.9; RI 0.021"),
    );
    let worst_second = iv[3].iter().cloned().fold(0.0, f64::max);
    rep.check(
        Check::below("IV second pole |z| (worst seed)", worst_second, 0.2)
            .with_note("spec A3.9: delay pole at 0; RI max 0.089"),
    );
    rep.check(
        Check::below(
            "closed-loop bias: median |DC − 0.5| of IV with f minus IV with u as instrument (§7.3 on closed-loop data)",
            med(&iv[1]) - med(&ivu[1]),
            0.0,
        )
        .with_note(format!(
            "u-instrument medians: e_step {:.3}, |DC − 0.5| {:.3}, |pole − 0.8187| {:.3}",
            med(&ivu[0]),
            med(&ivu[1]),
            med(&ivu[2])
        )),
    );
    rep.check(Check::below(
        "closed-loop bias: median e_step of IV with f minus IV with u as instrument",
        med(&iv[0]) - med(&ivu[0]),
        0.0,
    ));
    // Recorded, not asserted: plain N4SID (past outputs in W_p, state-sequence
    // regression) is NOT visibly biased on this loop (see the report).
    rep.figure("plain N4SID (p = f = 8) median e_step(60)", med(&n4[0]));
    rep.figure("plain N4SID median |DC − 0.5|", med(&n4[1]));
    rep.figure("plain N4SID median |pole − 0.8187|", med(&n4[2]));
    rep.figure("IV 90th-percentile e_step(60)", {
        let mut s = iv[0].clone();
        s.sort_by(|a, b| a.total_cmp(b));
        s[(s.len() * 9) / 10 - 1]
    });
    rep.figure("IV median |DC − 0.5|", med(&iv[1]));
    if let Some((seed, f_iv, u_iv)) = &shown {
        rep.plot(fig_7_12(&truth, f_iv, u_iv, *seed)?);
    }

    // Negative test (spec A3.9, erratum L-18): in the §7.8.2 multirate tank
    // the 0.9868 mode is seen only by the slow y₁, so Γ_R of (7.27) built
    // from the fast y₂ is rank deficient. Noise free, closed loop on y₂.
    let tank = stirred_tank_7_8_2()?;
    let n = 5000;
    let mut ex = DMatrix::zeros(n, 2);
    let u1 = rbs(n, 11)?;
    let f2 = rbs(n, 12)?;
    ex.column_mut(0).copy_from(&u1.column(0));
    let mut r1 = DMatrix::zeros(n, 2);
    r1.column_mut(1).copy_from(&f2.column(0));
    let out = tank.simulator()?.simulate(&Excitation::both(r1, ex))?;
    let u = out.u().clone();
    let mut instr = DMatrix::zeros(n, 2);
    instr.column_mut(0).copy_from(&u1.column(0));
    instr.column_mut(1).copy_from(&f2.column(0));
    let res = iv_multirate_fast(
        &u,
        &out.y,
        &instr,
        &[5, 1],
        &MultirateIvOptions {
            order: OrderSelection::Fixed(3),
            alpha: 4,
            ..Default::default()
        },
    );
    let (ok, what) = match &res {
        Err(SubspaceError::RankDeficient { rank, needed, .. }) => {
            (*rank < *needed, format!("rank {rank} < {needed}"))
        }
        Err(e) => (false, format!("other error: {e}")),
        Ok(_) => (false, "no error".to_string()),
    };
    rep.check(
        Check::holds(
            "(7.27) reports rank deficiency of Γ_R for the §7.8.2 tank",
            what,
            ok,
        )
        .with_note("erratum L-18: (C₂, A) not observable; use the two-step route"),
    );
    Ok(rep)
}

/// Medians over seeds of one closed-loop regime of the §7.8.2 SISO loop:
/// `[e_step(60), |DC − 0.5|, |dominant pole − 0.81873|]` for the IV method
/// (past dither as instrument, α = 8, α_p = 16) and for plain N4SID
/// (p = f = 8) on the same records.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegimeMedians {
    /// IV medians.
    pub iv: [f64; 3],
    /// Plain N4SID medians.
    pub n4sid: [f64; 3],
    /// Signed medians of DC − 0.5 (IV, plain N4SID): a bias shows as a
    /// median away from 0 of the sign-consistent errors.
    pub signed_dc: [f64; 2],
    /// Records whose DC gain estimate is below the true 0.5 (IV, plain
    /// N4SID): near half of the successful records for an unbiased
    /// estimate, nearly all (or none) for a biased one.
    pub dc_below: [usize; 2],
    /// Records on which a method returned an error (IV, plain N4SID);
    /// they are left out of the medians.
    pub failures: [usize; 2],
}

/// Simulates `seeds` records of `n` samples at variance SNR `snr` (spec §0
/// definition; the dither is RBS ±1 at the plant input) and identifies each
/// with both methods. Seeds `seed_base + s` (noise) and `seed_base + 1000 + s`
/// (dither).
pub fn regime(snr: f64, n: usize, seeds: u64, seed_base: u64) -> BoxResult<RegimeMedians> {
    let fx = chapter7_siso()?;
    let truth = fx.discrete_plant()?.model().clone();
    // Per method (0 = IV, 1 = plain N4SID): the three metrics and the signed
    // DC error of each record; an estimate without them (an error, or e.g. a
    // pole at z = 1) counts as a failure of its method.
    let mut errs = [
        [Vec::new(), Vec::new(), Vec::new()],
        [Vec::new(), Vec::new(), Vec::new()],
    ];
    let mut signed = [Vec::new(), Vec::new()];
    let mut failures = [0, 0];
    let scored = |m: &StateSpace| -> BoxResult<([f64; 4], f64)> {
        Ok((metrics(m, &truth)?, m.dc_gain()?[(0, 0)] - 0.5))
    };
    for seed in 0..seeds {
        let noise = fx
            .noise_spec(snr, SnrDefinition::Variance, seed_base + seed)
            .ok_or("fixture without noise model")?;
        let sim = fx.simulator()?.with_noise(noise)?;
        let f = rbs(n, seed_base + 1000 + seed)?;
        let out = sim.simulate(&Excitation::input(f.clone()))?;
        let (u, y) = (out.u(), &out.y);
        let iv = iv_identify(
            &[IvExperiment {
                u,
                y,
                instrument: Some(&f),
            }],
            &iv_options(),
        )
        .map(|m| m.model);
        let plain = identify(&[Experiment { u, y }], &n4sid_options()).map(|m| m.model);
        for (method, model) in [iv, plain].into_iter().enumerate() {
            match model.map_err(BoxErr::from).and_then(|m| scored(&m)) {
                Ok((mv, d)) => {
                    for (k, v) in mv.iter().take(3).enumerate() {
                        errs[method][k].push(*v);
                    }
                    signed[method].push(d);
                }
                Err(_) => failures[method] += 1,
            }
        }
    }
    let meds = |e: &[Vec<f64>; 3]| [median(&e[0]), median(&e[1]), median(&e[2])];
    let below = |v: &[f64]| v.iter().filter(|&&d| d < 0.0).count();
    Ok(RegimeMedians {
        iv: meds(&errs[0]),
        n4sid: meds(&errs[1]),
        signed_dc: [median(&signed[0]), median(&signed[1])],
        dc_below: [below(&signed[0]), below(&signed[1])],
        failures,
    })
}

/// Variance SNR of the bias experiment ([`run_bias`]), fixed a priori.
pub const BIAS_SNR: f64 = 0.5;
/// Shorter record length of the bias experiment (the spec's 3000); the
/// longer one is 4× this.
pub const BIAS_N: usize = 3000;
/// Seeds of the bias experiment (medians).
pub const BIAS_SEEDS: u64 = 20;
/// First seed of the bias experiment (disjoint from [`run`]'s 300…/700…).
pub const BIAS_SEED_BASE: u64 = 5000;

/// Second experiment of A3.9 (issue 7; not a spec check): the closed-loop
/// bias of plain N4SID against the IV method, on the same plant,
/// controller, disturbance and dither as [`run`], in a regime fixed before
/// looking at the outcome.
///
/// Why this regime shows bias. N4SID's oblique projection assumes the
/// future inputs U_f uncorrelated with the future innovations E_f. In this
/// loop u(k) = S(q)f(k) − S(q)G(q)v(k) (erratum L-17, dither at the plant
/// input; the controller 0.25z/(z − 1) even feeds v(k) through to u(k) in
/// the same sample), so U_f is correlated with E_f through the feedback,
/// and the projection error grows with the share of u that comes from the
/// noise; it is a bias, the same for every record length. The IV method
/// uses only the past dither f as instrument, independent of v, and is
/// consistent. At the spec's var-SNR 2.5 the feedback share is small and
/// N4SID's bias (median |DC − 0.5| ≈ 0.03) is below the IV scatter at
/// N = 3000, which is why [`run`] cannot assert "IV closer". Here the noise
/// variance is twice the dither-driven output variance (var-SNR 0.5; with
/// the spec §0 definition this is the same as a dither 1/√5 ≈ 0.45 of the
/// spec's at the spec's noise level), and the experiment is repeated with a
/// 4× longer record: a bias keeps its size and its sign across seeds,
/// variance shrinks and has no preferred sign.
pub fn run_bias() -> BoxResult<Reproduction> {
    let mut rep = Reproduction::new(
        "A3.9",
        "§7.8.2 SISO loop, noise-dominated regime: closed-loop bias of plain N4SID against the IV method",
    );
    let short = regime(BIAS_SNR, BIAS_N, BIAS_SEEDS, BIAS_SEED_BASE)?;
    let long = regime(BIAS_SNR, 4 * BIAS_N, BIAS_SEEDS, BIAS_SEED_BASE)?;
    let total = BIAS_SEEDS as usize;
    rep.check(Check::holds(
        "every record identified by both methods",
        format!(
            "failures IV/N4SID: N = {}: {:?}; N = {}: {:?}",
            BIAS_N,
            short.failures,
            4 * BIAS_N,
            long.failures
        ),
        short.failures == [0, 0] && long.failures == [0, 0],
    ));
    let names = ["e_step(60)", "|DC − 0.5|", "|pole − 0.8187|"];
    for (len, r) in [(BIAS_N, &short), (4 * BIAS_N, &long)] {
        for (k, name) in names.iter().enumerate() {
            rep.check(
                Check::below(
                    format!("var-SNR {BIAS_SNR}, N = {len}: median {name} of IV minus plain N4SID"),
                    r.iv[k] - r.n4sid[k],
                    0.0,
                )
                .with_note(format!(
                    "IV {:.3}, plain N4SID (p = f = 8) {:.3}; {total} seeds",
                    r.iv[k], r.n4sid[k]
                )),
            );
        }
    }
    // Bias, not variance: N4SID's error keeps its size when N grows 4×
    // (variance alone would halve it; 0.8 leaves room for the scatter of a
    // 20-seed median) and keeps its sign on nearly every record.
    for (k, name) in [(1, "|DC − 0.5|"), (2, "|pole − 0.8187|")] {
        rep.check(
            Check::above(
                format!(
                    "plain N4SID median {name}: N = {} over N = {}",
                    4 * BIAS_N,
                    BIAS_N
                ),
                long.n4sid[k] / short.n4sid[k],
                0.8,
            )
            .with_note(format!(
                "{:.3} → {:.3}; IV {:.3} → {:.3} (ratio {:.2})",
                short.n4sid[k],
                long.n4sid[k],
                short.iv[k],
                long.iv[k],
                long.iv[k] / short.iv[k]
            )),
        );
    }
    let frac = |c: usize, r: &RegimeMedians, m: usize| c as f64 / (total - r.failures[m]) as f64;
    rep.check(
        Check::above(
            format!(
                "plain N4SID, N = {}: share of records with DC < 0.5",
                4 * BIAS_N
            ),
            frac(long.dc_below[1], &long, 1),
            0.85,
        )
        .with_note(format!(
            "signed median DC − 0.5: {:.3} (N = {}), {:.3} (N = {})",
            short.signed_dc[1],
            BIAS_N,
            long.signed_dc[1],
            4 * BIAS_N
        )),
    );
    rep.check(
        Check::within(
            format!("IV, N = {}: share of records with DC < 0.5", 4 * BIAS_N),
            frac(long.dc_below[0], &long, 0),
            0.2,
            0.8,
        )
        .with_note(format!(
            "no preferred sign (binomial ½ ± 3σ for 20 records); signed median DC − 0.5: {:.3} (N = {}), {:.3} (N = {})",
            short.signed_dc[0],
            BIAS_N,
            long.signed_dc[0],
            4 * BIAS_N
        )),
    );
    // Recorded, not asserted: the IV medians do not shrink like 1/√N. With
    // 60 seeds (base 9000, exploration while writing this experiment) IV's
    // median |DC − 0.5| was 0.050 / 0.034 / 0.038 and |pole − 0.8187| 0.034 /
    // 0.020 / 0.026 for N = 3000 / 12000 / 48000, sign-balanced (33 of 60
    // records below 0.5), against N4SID's 0.098 / 0.095 / 0.096 (60 of 60
    // below). So the "IV shrinks with N" half of the signature is not
    // asserted; the sign balance above is the part that holds.
    rep.figure(
        "IV median |DC − 0.5|, N = 4·3000 over N = 3000",
        long.iv[1] / short.iv[1],
    );
    rep.figure(
        "IV median |pole − 0.8187|, N = 4·3000 over N = 3000",
        long.iv[2] / short.iv[2],
    );
    // The spec's own SNR with a long record: N4SID's bias is there too,
    // hidden at N = 3000 by the IV scatter (recorded, not asserted).
    let spec_long = regime(2.5, 16 * BIAS_N, BIAS_SEEDS, BIAS_SEED_BASE)?;
    rep.figure(
        "var-SNR 2.5, N = 48000: IV median e_step(60)",
        spec_long.iv[0],
    );
    rep.figure(
        "var-SNR 2.5, N = 48000: IV median |DC − 0.5|",
        spec_long.iv[1],
    );
    rep.figure(
        "var-SNR 2.5, N = 48000: IV signed median DC − 0.5",
        spec_long.signed_dc[0],
    );
    rep.figure(
        "var-SNR 2.5, N = 48000: plain N4SID median e_step(60)",
        spec_long.n4sid[0],
    );
    rep.figure(
        "var-SNR 2.5, N = 48000: plain N4SID median |DC − 0.5|",
        spec_long.n4sid[1],
    );
    rep.figure(
        "var-SNR 2.5, N = 48000: plain N4SID signed median DC − 0.5",
        spec_long.signed_dc[1],
    );
    Ok(rep)
}
