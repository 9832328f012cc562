//! H∞ and H2 norms against closed forms.

use lifted_lti::{HinfOptions, StateSpace, append};

use crate::common::*;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// ωₙ²/(s² + 2ζωₙs + ωₙ²): peak 1/(2ζ√(1−ζ²)) at ωₙ√(1−2ζ²).
#[test]
fn hinf_lightly_damped_second_order() {
    for &(zeta, wn) in &[
        (0.05, 3.0),
        (0.01, 0.5),
        (0.3, 10.0),
        (1e-3, 100.0),
        (1e-4, 0.01),
    ] {
        let g = tf(&[wn * wn], &[1.0, 2.0 * zeta * wn, wn * wn], None)
            .to_ss()
            .unwrap();
        let opts = HinfOptions::default();
        let h = g.hinf_norm(&opts).unwrap();
        let peak = 1.0 / (2.0 * zeta * (1.0 - zeta * zeta).sqrt());
        // the result is a lower bound within (1 + 2 rel_tol)
        assert!(
            rel(h.norm, peak) <= 2.0 * opts.rel_tol + 1e-12,
            "ζ={zeta}: {} vs {peak}",
            h.norm
        );
        let wpk = wn * (1.0 - 2.0 * zeta * zeta).sqrt();
        // σ is flat at the peak: frequency error ~ sqrt(rel_tol)
        assert!(
            rel(h.peak_frequency, wpk) < 1e-3,
            "{} vs {wpk}",
            h.peak_frequency
        );
    }
}

/// 1/(z − a): peak 1/(1−a) at θ = 0 (a > 0) or 1/(1−|a|) at θ = π (a < 0,
/// pole near z = −1 exercises the rotated bilinear map).
#[test]
fn hinf_discrete_first_order() {
    let t = 0.1;
    for &a in &[0.7, -0.9, -0.999, 0.5] {
        let g = tf(&[1.0], &[1.0, -a], Some(t)).to_ss().unwrap();
        let h = g.hinf_norm(&HinfOptions::default()).unwrap();
        let want = 1.0 / (1.0 - a.abs());
        assert!(rel(h.norm, want) < 3e-8, "a={a}: {} vs {want}", h.norm);
        let theta = h.peak_frequency * t;
        let want_theta = if a > 0.0 { 0.0 } else { std::f64::consts::PI };
        assert!((theta - want_theta).abs() < 1e-3, "a={a}: θ = {theta}");
    }
}

/// Discrete second-order resonance, compared with a dense grid.
#[test]
fn hinf_discrete_resonance_vs_grid() {
    let g = tf(&[0.1, 0.05], &[1.0, -1.6, 0.95], Some(0.01))
        .to_ss()
        .unwrap();
    let h = g.hinf_norm(&HinfOptions::default()).unwrap();
    let grid: Vec<f64> = (0..=200_000)
        .map(|k| k as f64 * std::f64::consts::PI / 0.01 / 200_000.0)
        .collect();
    let best = g
        .freqresp(&grid)
        .unwrap()
        .iter()
        .map(|m| m[(0, 0)].norm())
        .fold(0.0, f64::max);
    assert!(h.norm >= best * (1.0 - 1e-9), "{} < grid {best}", h.norm);
    assert!(rel(h.norm, best) < 1e-5);
}

/// MIMO diagonal: the norm is the largest of the diagonal norms; D ≠ 0 handled.
#[test]
fn hinf_mimo_diagonal_and_feedthrough() {
    let g1 = tf(&[4.0], &[1.0, 0.4, 4.0], None).to_ss().unwrap(); // ζ = 0.1, peak 5.0252
    let g2 = tf(&[2.0, 1.0], &[1.0, 1.0], None).to_ss().unwrap(); // (2s+1)/(s+1): peak 2 at ω = ∞
    let g = append(&g1, &g2).unwrap();
    let h = g.hinf_norm(&HinfOptions::default()).unwrap();
    let peak = 1.0 / (2.0 * 0.1 * (1.0f64 - 0.01).sqrt());
    assert!(rel(h.norm, peak) < 3e-8);
    let h2 = g2.hinf_norm(&HinfOptions::default()).unwrap();
    assert!(rel(h2.norm, 2.0) < 3e-8);
    assert!(h2.peak_frequency.is_infinite());
    let tight = HinfOptions {
        rel_tol: 1e-4,
        ..HinfOptions::default()
    };
    assert!(rel(g1.hinf_norm(&tight).unwrap().norm, peak) < 2e-4 + 1e-12);
}

/// H2 vs Gramian closed forms: 1/(s+a) → 1/√(2a); 1/(z−a) → 1/√(1−a²);
/// 0.5 + 1/(z − 0.5) → √(0.25 + 1/0.75).
#[test]
fn h2_closed_forms() {
    let a = 3.0;
    let g = tf(&[1.0], &[1.0, a], None).to_ss().unwrap();
    assert!(rel(g.h2_norm().unwrap(), 1.0 / (2.0 * a).sqrt()) < 1e-12);
    let gd = tf(&[1.0], &[1.0, -0.6], Some(1.0)).to_ss().unwrap();
    assert!(rel(gd.h2_norm().unwrap(), 1.0 / (1.0f64 - 0.36).sqrt()) < 1e-12);
    let gdd = tf(&[0.5, 0.75], &[1.0, -0.5], Some(1.0)).to_ss().unwrap();
    assert!(rel(gdd.h2_norm().unwrap(), (0.25f64 + 1.0 / 0.75).sqrt()) < 1e-12);
    // ωₙ²/(s²+2ζωₙs+ωₙ²): ‖G‖₂² = ωₙ/(4ζ)
    let (z, wn) = (0.2, 2.0);
    let g2 = tf(&[wn * wn], &[1.0, 2.0 * z * wn, wn * wn], None)
        .to_ss()
        .unwrap();
    assert!(rel(g2.h2_norm().unwrap(), (wn / (4.0 * z)).sqrt()) < 1e-12);
    // MIMO: squares add
    let m = append(&g, &g2).unwrap();
    let want = (1.0 / (2.0 * a) + wn / (4.0 * z)).sqrt();
    assert!(rel(m.h2_norm().unwrap(), want) < 1e-12);
}

#[test]
fn norms_reject_unstable_and_infinite() {
    let g = tf(&[1.0], &[1.0, -1.0], None).to_ss().unwrap();
    assert!(matches!(
        g.hinf_norm(&HinfOptions::default()),
        Err(lifted_lti::Error::Unstable { .. })
    ));
    assert!(matches!(
        g.h2_norm(),
        Err(lifted_lti::Error::Unstable { .. })
    ));
    let biproper = StateSpace::new(
        mat(1, 1, &[-1.0]),
        mat(1, 1, &[1.0]),
        mat(1, 1, &[1.0]),
        mat(1, 1, &[1.0]),
        None,
    )
    .unwrap();
    assert!(matches!(
        biproper.h2_norm(),
        Err(lifted_lti::Error::Infinite { .. })
    ));
}

/// Lightly damped discrete pair near z = −1 (r = 0.999, θ₀ = 3.1): the
/// rotated bilinear map keeps the computation well conditioned. Reference:
/// a fine local grid around θ₀ (σ is flat at the peak, so the grid maximum is
/// within ~1e-9 of the true one).
#[test]
fn hinf_discrete_resonance_near_minus_one() {
    let (r, th, t) = (0.999f64, 3.1f64, 0.01);
    let g = tf(&[1.0], &[1.0, -2.0 * r * th.cos(), r * r], Some(t))
        .to_ss()
        .unwrap();
    let h = g.hinf_norm(&HinfOptions::default()).unwrap();
    let grid: Vec<f64> = (0..=200_000)
        .map(|k| (th - 0.01 + 0.02 * k as f64 / 200_000.0) / t)
        .collect();
    let best = g
        .freqresp(&grid)
        .unwrap()
        .iter()
        .map(|m| m[(0, 0)].norm())
        .fold(0.0, f64::max);
    assert!(h.norm >= best * (1.0 - 1e-9), "{} < {best}", h.norm);
    assert!(rel(h.norm, best) < 1e-7, "{} vs {best}", h.norm);
    assert!((h.peak_frequency * t - th).abs() < 1e-3);
}
