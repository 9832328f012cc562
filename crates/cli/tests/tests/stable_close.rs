use super::*;
use lifted_sim::SnrDefinition;
use nalgebra::Complex;

/// 2×2, four states (0.99, 0.9, 0.8 ± 0.3j).
fn plant() -> StateSpace {
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            0.99, 0.0, 0.0, 0.0, 0.0, 0.9, 0.0, 0.0, 0.0, 0.0, 0.8, 0.3, 0.0, 0.0, -0.3, 0.8,
        ],
    );
    let b = DMatrix::from_row_slice(4, 2, &[1.0, 0.3, 0.2, 1.0, 0.5, -0.4, 0.3, 0.6]);
    let c = DMatrix::from_row_slice(2, 4, &[0.5, 0.2, 0.7, 0.0, 0.1, 0.6, 0.0, 0.5]);
    StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).unwrap()
}

/// N = 3000 samples of random binary inputs; output noise low-pass
/// filtered by 1/(1 − 0.995 z⁻¹) per output at a variance SNR of 4.
fn record(path: &str, seed: u64) {
    let n = 3000;
    let mut u = DMatrix::zeros(n, 2);
    for j in 0..2 {
        let col = rbs(n, 1000 * seed + j as u64);
        u.column_mut(j).copy_from_slice(&col);
    }
    let e = DMatrix::<f64>::identity(2, 2);
    let h = StateSpace::new(&e * 0.995, e.clone(), &e * 0.995, e.clone(), Some(1.0)).unwrap();
    let sim = Simulator::open_loop(Plant::discrete(&plant(), &[], &[]).unwrap())
        .with_inputs(vec![InputChannel::new("u1", 1), InputChannel::new("u2", 1)])
        .unwrap()
        .with_outputs(vec![
            OutputChannel::new("y1", 1, 0),
            OutputChannel::new("y2", 1, 0),
        ])
        .unwrap()
        .with_noise(NoiseSpec::filtered(h, 4.0, SnrDefinition::Variance, seed))
        .unwrap();
    let out = sim.simulate(&Excitation::input(u)).unwrap();
    out.data
        .to_csv_writer(std::fs::File::create(path).unwrap())
        .unwrap();
}

/// Relative frequency-response error against the plant on 200
/// frequencies spread linearly over (0, π].
fn fr_error(m: &StateSpace) -> f64 {
    let w: Vec<f64> = (1..=200)
        .map(|k| k as f64 * std::f64::consts::PI / 200.0)
        .collect();
    let (gt, gm) = (plant().freqresp(&w).unwrap(), m.freqresp(&w).unwrap());
    let (mut num, mut den) = (0.0, 0.0);
    for (t, e) in gt.iter().zip(&gm) {
        num += (t - e).map(|z: Complex<f64>| z.norm_sqr()).sum();
        den += t.map(|z: Complex<f64>| z.norm_sqr()).sum();
    }
    (num / den).sqrt()
}

fn rho(m: &StateSpace) -> f64 {
    m.poles()
        .unwrap()
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max)
}

#[test]
fn stable_models_stay_close_to_the_data() {
    let d = tmp("stable-close");
    let data = p(&d, "rec.csv");
    let out = p(&d, "m.json");
    let base = [
        "identify",
        "--method",
        "n4sid",
        "--data",
        &data,
        "--inputs",
        "u1,u2",
        "--outputs",
        "y1,y2",
        "--order",
        "6",
        "--horizon",
        "10",
        "--estimator",
        "shift",
        "--refine",
        "none",
        "--out",
        &out,
    ];
    let mut checked = 0;
    for seed in 0..40 {
        record(&data, seed);
        ok(&base);
        let plain = ModelFile::read(&out).unwrap().model;
        if rho(&plain) < 1.0 {
            continue;
        }
        let mut stable = base.to_vec();
        stable.push("--stable");
        ok(&stable);
        let f = ModelFile::read(&out).unwrap();
        let m = f.model.clone();
        let (e_plain, e_stable) = (fr_error(&plain), fr_error(&m));
        eprintln!(
            "seed {seed}: rho {:.4}, FR error unconstrained {e_plain:.4}, --stable {e_stable:.4} ({})",
            rho(&plain),
            f.diagnostics["stable_route"]
        );
        assert!(rho(&m) < 1.0, "seed {seed}: rho {}", rho(&m));
        assert!(
            f.diagnostics["stable_route"].is_string(),
            "{}",
            f.diagnostics
        );
        // The bound: the stable model's FR error within 1.2× of
        // the unconstrained (unstable) one's.
        assert!(
            e_stable <= 1.2 * e_plain,
            "seed {seed}: stable {e_stable} vs unconstrained {e_plain}"
        );
        checked += 1;
        if checked == 3 {
            break;
        }
    }
    assert_eq!(checked, 3, "fewer than 3 unstable estimates in 40 records");
}
