//! Integration tests of lifted-pem: the state-space prediction-error
//! refinement (recovery, invariance, multirate records, keep-the-better
//! rule, rejected inputs) and the state-space covariance (coverage).

mod common {
    use lifted_lti::StateSpace;
    use nalgebra::{DMatrix, DVector};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    /// A stable system with the given real poles and complex pairs (r, θ),
    /// hidden behind a random similarity; B, C, D Gaussian.
    pub fn random_system(
        seed: u64,
        real: &[f64],
        pairs: &[(f64, f64)],
        nu: usize,
        ny: usize,
        with_d: bool,
    ) -> StateSpace {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = real.len() + 2 * pairs.len();
        let mut a = DMatrix::zeros(n, n);
        for (i, &p) in real.iter().enumerate() {
            a[(i, i)] = p;
        }
        for (k, &(r, th)) in pairs.iter().enumerate() {
            let i = real.len() + 2 * k;
            a[(i, i)] = r * th.cos();
            a[(i, i + 1)] = -r * th.sin();
            a[(i + 1, i)] = r * th.sin();
            a[(i + 1, i + 1)] = r * th.cos();
        }
        let mut gauss = |r: usize, c: usize| {
            DMatrix::from_fn(r, c, |_, _| rng.sample::<f64, _>(StandardNormal))
        };
        let t = gauss(n, n) + DMatrix::identity(n, n) * 3.0;
        let ti = t.clone().try_inverse().unwrap();
        let b = gauss(n, nu);
        let c = gauss(ny, n);
        let d = if with_d {
            gauss(ny, nu)
        } else {
            DMatrix::zeros(ny, nu)
        };
        StateSpace::new(&t * a * &ti, &t * b, c * ti, d, Some(1.0)).unwrap()
    }

    pub fn rbs(seed: u64, n: usize, m: usize) -> DMatrix<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        DMatrix::from_fn(n, m, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 })
    }

    pub fn white(seed: u64, n: usize, m: usize, sd: f64) -> DMatrix<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        DMatrix::from_fn(n, m, |_, _| sd * rng.sample::<f64, _>(StandardNormal))
    }

    /// Max relative frequency-response difference over a grid.
    pub fn freq_error(a: &StateSpace, b: &StateSpace) -> f64 {
        let w: Vec<f64> = (0..64).map(|k| 0.001 + k as f64 * 3.1 / 63.0).collect();
        let ga = a.freqresp(&w).unwrap();
        let gb = b.freqresp(&w).unwrap();
        let mut err: f64 = 0.0;
        for (x, y) in ga.iter().zip(gb.iter()) {
            let scale = y.iter().map(|v| v.norm()).fold(0.0, f64::max).max(1e-12);
            for (p, q) in x.iter().zip(y.iter()) {
                err = err.max((p - q).norm() / scale);
            }
        }
        err
    }

    pub fn sim(g: &StateSpace, u: &DMatrix<f64>, x0: Option<&DVector<f64>>) -> DMatrix<f64> {
        g.lsim(u, x0, None).unwrap().y
    }
}

mod suite {
    pub mod covariance;
    pub mod state_space;
}
