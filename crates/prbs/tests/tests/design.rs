use approx::assert_relative_eq;
use lifted_prbs::{DesignRequest, Error, InversePrbs, design};

/// Zhu 2000 Table II: a = 2, T = 0.01 s, 30 Hz injection, margin 3, slowest mode
/// 0.025 Hz → n = 8, T_p = 0.1 s, n_r = 10, period 51 s, f₀ = 1/51 Hz (Z-13).
#[test]
fn table_ii() {
    let p = design(&DesignRequest {
        output_period: 0.01,
        actuator_rate_hz: 30.0,
        actuator_margin: 3.0,
        slowest_mode_hz: 0.025,
        amplitude: 2.0,
        min_order: 2,
    })
    .unwrap();
    assert_eq!((p.order, p.m, p.hold), (8, 255, 10));
    assert_eq!(p.amplitude, 2.0);
    assert_relative_eq!(p.generation_period, 0.1, max_relative = 1e-12);
    assert_eq!(p.period_samples, 5100);
    assert_relative_eq!(p.record_length_s, 51.0, max_relative = 1e-12);
    assert_relative_eq!(p.fundamental_hz, 1.0 / 51.0, max_relative = 1e-12);
    assert!((p.fundamental_hz - 0.0196).abs() < 1e-4);
    assert_relative_eq!(p.band_high_hz, 5.0, max_relative = 1e-12);
    assert!(p.explanation.contains("n_r = ceil"));
    let prbs = InversePrbs::new(&p.prbs_options()).unwrap();
    assert_eq!(prbs.period(), 5100);
}

#[test]
fn fast_actuator_gives_no_hold() {
    let p = design(&DesignRequest {
        actuator_rate_hz: 1000.0,
        ..Default::default()
    })
    .unwrap();
    assert_eq!(p.hold, 1);
}

#[test]
fn infeasible() {
    let e = design(&DesignRequest {
        slowest_mode_hz: 1e-12,
        ..Default::default()
    })
    .unwrap_err();
    assert!(matches!(e, Error::DesignInfeasible { .. }));
}
