//! Checks of the records and matrices a caller hands in, with this crate's
//! errors.

use nalgebra::DMatrix;

use crate::error::{Error, Result};

/// [`Error::DimensionMismatch`] for `what` unless `u` is N×`nu` and `y`
/// N×`ny` for some N.
pub(crate) fn check_record_shape(
    what: &'static str,
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    nu: usize,
    ny: usize,
) -> Result<()> {
    if u.ncols() != nu || y.ncols() != ny || u.nrows() != y.nrows() {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("N×{nu} and N×{ny}"),
            got: format!(
                "{}x{} and {}x{}",
                u.nrows(),
                u.ncols(),
                y.nrows(),
                y.ncols()
            ),
        });
    }
    Ok(())
}

/// [`Error::NonFinite`] at the first NaN or infinity of `m` (by column,
/// then row), O(size) vectorised.
pub(crate) fn check_finite(what: &'static str, m: &DMatrix<f64>) -> Result<()> {
    match lifted_linalg::first_non_finite(m.as_slice()) {
        Some(i) => Err(Error::NonFinite {
            what,
            row: i % m.nrows(),
            col: i / m.nrows(),
        }),
        None => Ok(()),
    }
}

/// The checks every polynomial estimator shares: records given, `orders`
/// shaped for their n_u inputs and n_y outputs (na n_y×n_y; nb, nf, nk
/// n_y×n_u; nc, nd per output), an F only where there is a B, u finite,
/// y finite — or NaN where it was not measured when `unmeasured_y` —
/// and every record of the same shape. Returns (n_u, n_y). O(N).
pub(crate) fn check_polynomial_records(
    experiments: &[lifted_subspace::Experiment<'_>],
    orders: &lifted_lti::PolyOrders,
    unmeasured_y: bool,
) -> Result<(usize, usize)> {
    let first = experiments.first().ok_or(Error::NoData)?;
    let (nu, ny) = (first.u.ncols(), first.y.ncols());
    let grid = |m: &Vec<Vec<usize>>, rows: usize, cols: usize| {
        m.len() == rows && m.iter().all(|r| r.len() == cols)
    };
    if !(grid(&orders.na, ny, ny)
        && grid(&orders.nb, ny, nu)
        && grid(&orders.nf, ny, nu)
        && grid(&orders.nk, ny, nu)
        && orders.nc.len() == ny
        && orders.nd.len() == ny)
    {
        return Err(Error::DimensionMismatch {
            what: "polynomial orders (na n_y×n_y, nb, nf, nk n_y×n_u, nc, nd per output)",
            expected: format!("{ny} outputs and {nu} inputs"),
            got: format!(
                "nb {}×{}",
                orders.nb.len(),
                orders.nb.first().map_or(0, Vec::len)
            ),
        });
    }
    for (i, row) in orders.nb.iter().enumerate() {
        if row
            .iter()
            .zip(&orders.nf[i])
            .any(|(&b, &f)| b == 0 && f > 0)
        {
            return Err(Error::InvalidOption {
                what: "orders",
                reason: format!("output {i}: an input with nb = 0 has no F (nf must be 0)"),
            });
        }
    }
    for e in experiments {
        check_record_shape("record (u, y)", e.u, e.y, nu, ny)?;
        check_finite("u", e.u)?;
        if unmeasured_y {
            if let Some(k) = e.y.iter().position(|v| v.is_infinite()) {
                return Err(Error::NonFinite {
                    what: "y",
                    row: k % e.y.nrows(),
                    col: k / e.y.nrows(),
                });
            }
        } else {
            check_finite("y", e.y)?;
        }
    }
    Ok((nu, ny))
}
