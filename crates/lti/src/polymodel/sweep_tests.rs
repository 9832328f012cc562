use super::convert::tests::model_diff;
use super::*;
use num_complex::Complex64;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A monic polynomial in q⁻¹ of degree n with roots of modulus < 0.85.
fn stable(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    let mut roots = Vec::new();
    while roots.len() < n {
        let r = rng.random_range(0.1..0.85);
        if n - roots.len() >= 2 && rng.random_range(0.0..1.0) < 0.5 {
            let th = rng.random_range(0.2..3.0);
            roots.push(Complex64::from_polar(r, th));
            roots.push(Complex64::from_polar(r, -th));
        } else {
            roots.push(Complex64::new(
                if rng.random_range(0.0..1.0) < 0.5 {
                    r
                } else {
                    -r
                },
                0.0,
            ));
        }
    }
    crate::Poly::from_roots(&roots).unwrap().coeffs().to_vec()
}

fn random_model(rng: &mut ChaCha8Rng, family: PolyFamily) -> PolyModel {
    let mut deg = |lo: usize, hi: usize| rng.random_range(lo..=hi);
    let (na, nc, nd, nf) = match family {
        PolyFamily::Arx => (deg(1, 4), 0, 0, 0),
        PolyFamily::Armax => (deg(1, 3), deg(1, 3), 0, 0),
        PolyFamily::Oe => (0, 0, 0, deg(1, 4)),
        PolyFamily::Bj => (0, deg(1, 2), deg(1, 2), deg(1, 3)),
        PolyFamily::Fir => (0, 0, 0, 0),
        PolyFamily::General => (deg(1, 2), deg(0, 2), deg(1, 2), deg(1, 2)),
    };
    let nb = deg(1, 3);
    let nk = deg(0, 3);
    let b: Vec<f64> = (0..nb).map(|_| rng.random_range(-1.0..1.0)).collect();
    let a = stable(rng, na);
    let c = stable(rng, nc);
    let d = stable(rng, nd);
    let f = stable(rng, nf);
    PolyModel::siso(&a, &b, &c, &d, &f, nk, 0.1).unwrap()
}

#[test]
fn random_structures_satisfy_identities() {
    use PolyFamily::*;
    let mut rng = ChaCha8Rng::seed_from_u64(49);
    let u = DMatrix::from_fn(300, 1, |t, _| ((t * 7919 % 23) as f64 - 11.0) / 11.0);
    let e = DMatrix::from_fn(300, 1, |t, _| ((t * 104_729 % 19) as f64 - 9.0) / 90.0);
    for round in 0..40 {
        for family in [Arx, Armax, Oe, Bj, Fir, General] {
            let m = random_model(&mut rng, family);
            let what = format!("round {round}, {family:?}: {:?}", m.polynomials());
            let y = m.simulate(&u, Some(&e)).unwrap();
            let scale = y.amax().max(1.0);
            let y_ss = m.to_ss().unwrap().lsim(&u, None, None).unwrap().y;
            let y0 = m.simulate(&u, None).unwrap();
            assert!((&y0 - &y_ss).amax() < 1e-10 * scale, "{what}");
            let direct = m.predict_one_step(&u, &y).unwrap();
            let kalman = m.predict(&u, &y, 1).unwrap();
            assert!((&direct - &kalman).amax() < 1e-10 * scale, "{what}");
            let back = match family {
                Arx | Armax => {
                    let (ss, k) = m.to_innovations_ss().unwrap();
                    PolyModel::from_ss(&ss, Some(&k)).unwrap()
                }
                Oe | Fir => PolyModel::from_ss(&m.to_ss().unwrap(), None).unwrap(),
                Bj => {
                    let (ss, k) = m.to_innovations_ss().unwrap();
                    PolyModel::from_ss_bj(&ss, &k).unwrap()
                }
                General => continue,
            };
            let d = model_diff(&back, &m);
            assert!(d < 1e-9, "{what}: {d}");
        }
    }
}
