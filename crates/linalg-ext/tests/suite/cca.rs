//! Canonical correlation analysis: invariants and a covariance-based
//! reference computation.

use lifted_linalg::*;
use nalgebra::DMatrix;

use super::gaussian;

#[test]
fn weights_whiten_and_diagonalise() {
    let n = 500;
    let x = gaussian(3, n, 1);
    // y depends on x plus noise.
    let mix = DMatrix::from_row_slice(2, 3, &[1.0, 0.5, 0.0, 0.0, 0.2, 1.0]);
    let y = &mix * &x + gaussian(2, n, 2) * 0.7;
    let c = cca(&x, &y).unwrap();
    assert_eq!(c.correlations.len(), 2);
    assert_eq!((c.x_weights.shape(), c.y_weights.shape()), ((3, 2), (2, 2)));
    assert!(
        c.correlations[0] >= c.correlations[1]
            && c.correlations[1] >= 0.0
            && c.correlations[0] <= 1.0
    );
    let u = c.x_weights.transpose() * &x;
    let v = c.y_weights.transpose() * &y;
    let nf = n as f64;
    let i2 = DMatrix::identity(2, 2);
    assert!((&u * u.transpose() / nf - &i2).norm() < 1e-12);
    assert!((&v * v.transpose() / nf - &i2).norm() < 1e-12);
    let cross = &u * v.transpose() / nf;
    assert!((cross - DMatrix::from_diagonal(&c.correlations)).norm() < 1e-12);
}

#[test]
fn correlations_match_covariance_formula() {
    // Reference: ρ² = eig(Σxx⁻¹ Σxy Σyy⁻¹ Σyx), computed here from the
    // (well-conditioned) covariances — fine for a test, not for the kernel.
    let n = 300;
    let x = gaussian(4, n, 3);
    let y = DMatrix::from_fn(3, n, |i, j| x[(i, j)] * 0.8) + gaussian(3, n, 4);
    let (sxx, syy, sxy) = (&x * x.transpose(), &y * y.transpose(), &x * y.transpose());
    let m = solve(&sxx, &sxy).unwrap() * solve(&syy, &sxy.transpose()).unwrap();
    let mut ref_rho: Vec<f64> = eigenvalues(&m)
        .unwrap()
        .iter()
        .map(|l| l.re.max(0.0).sqrt())
        .collect();
    ref_rho.sort_by(|a, b| b.total_cmp(a));
    let c = cca(&x, &y).unwrap();
    for (k, rho) in c.correlations.iter().enumerate() {
        assert!(
            (rho - ref_rho[k]).abs() < 1e-10,
            "ρ{k}: {rho} vs {}",
            ref_rho[k]
        );
    }
}

#[test]
fn centred_and_uncentred_differ_only_by_means() {
    let n = 200;
    let x = gaussian(2, n, 5).add_scalar(3.0);
    let y = gaussian(2, n, 6).add_scalar(-1.0);
    let raw = cca(&x, &y).unwrap();
    let centred = cca(&center_rows(&x).unwrap(), &center_rows(&y).unwrap()).unwrap();
    // Independent data: centred correlations are small (≈ N^{-1/2}), but
    // the common offsets correlate the raw second moments. Population value
    // of the first raw correlation, with u = 1ᵀx (mean 6, variance 2) and
    // v = 1ᵀy (mean −2, variance 2):
    // |E uv| / √(E u² E v²) = 12/√(38·6) = 0.7947. The tolerance 0.06 is
    // about 2–3 standard errors of a sample correlation at N = 200.
    assert!(centred.correlations[0] < 0.3);
    assert!(
        (raw.correlations[0] - 0.7947).abs() < 0.06,
        "{}",
        raw.correlations[0]
    );
}

#[test]
fn rejects_short_or_rank_deficient_data() {
    let x = gaussian(3, 4, 1);
    let y = gaussian(2, 4, 2);
    assert!(matches!(
        cca(&x, &y),
        Err(Error::NotEnoughData {
            got: 4,
            needed: 5,
            ..
        })
    ));
    let mut x = gaussian(3, 50, 1);
    let r0 = x.row(0).into_owned();
    x.row_mut(2).copy_from(&(r0 * 2.0));
    let y = gaussian(2, 50, 2);
    assert!(matches!(
        cca(&x, &y),
        Err(Error::RankDeficient {
            what: "x",
            rank: 2,
            needed: 3
        })
    ));
    assert!(matches!(
        cca(&y, &DMatrix::zeros(1, 50)),
        Err(Error::RankDeficient { what: "y", .. })
    ));
    assert!(matches!(
        cca(&gaussian(2, 50, 1), &gaussian(2, 49, 2)),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        cca(&DMatrix::zeros(0, 5), &gaussian(2, 5, 2)),
        Err(Error::Empty { what: "x" })
    ));
}
