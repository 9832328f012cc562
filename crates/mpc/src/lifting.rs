//! Lifting of discrete LTI and n-periodic systems (thesis §9.2, §9.4) and
//! lifted frequency responses.
//!
//! Ordering: time-major — the lifted input/output stacks the samples
//! k = 0 … n−1 of one period, each sample carrying all channels.

use lifted_lti::StateSpace;
use lifted_multirate::{MultirateLifting, Ordering, lift_model};
use nalgebra::DMatrix;

pub use crate::complex_svd::sigma_max;
use crate::error::{Error, Result};

/// One phase of an n-periodic system x(k+1) = A_k x + B_k w, z = C_k x + D_k w.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicStep {
    /// A_k.
    pub a: DMatrix<f64>,
    /// B_k.
    pub b: DMatrix<f64>,
    /// C_k.
    pub c: DMatrix<f64>,
    /// D_k.
    pub d: DMatrix<f64>,
}

/// Lifts an n-periodic system to an LTI one at period nT:
/// Ā = A_{n−1}⋯A_0, B̄_j = A_{n−1}⋯A_{j+1}B_j, C̄_i = C_iA_{i−1}⋯A_0,
/// D̄_{ij} = C_iA_{i−1}⋯A_{j+1}B_j (i > j), D_i (i = j), 0 (i < j).
/// `ts` is the fast sample time. O(n² order² (inputs + outputs)).
///
/// Errors: empty or inconsistent phases, non-finite data.
pub fn lift_periodic(steps: &[PeriodicStep], ts: f64) -> Result<StateSpace> {
    let n = steps.len();
    let Some(first) = steps.first() else {
        return Err(Error::InvalidArgument {
            what: "periodic steps",
            reason: "need at least one phase".into(),
        });
    };
    let (nx, nw, nz) = (first.a.nrows(), first.b.ncols(), first.c.nrows());
    for s in steps {
        if s.a.shape() != (nx, nx)
            || s.b.shape() != (nx, nw)
            || s.c.shape() != (nz, nx)
            || s.d.shape() != (nz, nw)
        {
            return Err(Error::DimensionMismatch {
                what: "periodic phase matrices",
                expected: nx,
                got: s.a.nrows(),
            });
        }
    }
    // phi[i] = A_{i-1}⋯A_0 (phi[0] = I)
    let mut phi = vec![DMatrix::identity(nx, nx)];
    for s in steps {
        let next = &s.a
            * phi
                .last()
                .map_or_else(|| DMatrix::identity(nx, nx), Clone::clone);
        phi.push(next);
    }
    let abar = phi[n].clone();
    let mut bbar = DMatrix::zeros(nx, n * nw);
    let mut cbar = DMatrix::zeros(n * nz, nx);
    let mut dbar = DMatrix::zeros(n * nz, n * nw);
    for j in 0..n {
        // transition from j+1 to i: A_{i-1}⋯A_{j+1}
        let mut tr = DMatrix::identity(nx, nx);
        for i in (j + 1)..=n {
            if i == n {
                bbar.columns_mut(j * nw, nw).copy_from(&(&tr * &steps[j].b));
            } else {
                dbar.view_mut((i * nz, j * nw), (nz, nw))
                    .copy_from(&(&steps[i].c * &tr * &steps[j].b));
                tr = &steps[i].a * tr;
            }
        }
        dbar.view_mut((j * nz, j * nw), (nz, nw))
            .copy_from(&steps[j].d);
        cbar.rows_mut(j * nz, nz)
            .copy_from(&(&steps[j].c * &phi[j]));
    }
    Ok(StateSpace::new(
        abar,
        bbar,
        cbar,
        dbar,
        Some(ts * n as f64),
    )?)
}

/// Lifts a discrete LTI system by n (𝐏 = L_n P L_n⁻¹, §9.2), time-major
/// ordering, through `lifted-multirate` (`lift_model` with a uniform
/// lifting; the general D̄ entry of Prop. 1 handles D ≠ 0).
///
/// Errors: continuous model, `n = 0`.
pub fn lift(sys: &StateSpace, n: usize) -> Result<StateSpace> {
    crate::model::discrete_ts("system to lift", sys)?;
    crate::error::check_at_least_one("lifting factor n", n)?;
    let l = MultirateLifting::uniform(n, sys.n_inputs(), sys.n_outputs(), Ordering::TimeMajor)?;
    Ok(lift_model(sys, &l)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::dmatrix;

    #[test]
    fn lifted_markov_structure() {
        // y(k) = 0.5 y(k−1) + u(k−1): lifted D̄ by 3 has CB, CAB below the diagonal
        let s = StateSpace::new(
            dmatrix![0.5],
            dmatrix![1.0],
            dmatrix![1.0],
            dmatrix![0.0],
            Some(1.0),
        )
        .unwrap();
        let l = lift(&s, 3).unwrap();
        assert_eq!(
            l.d(),
            &dmatrix![0.0, 0.0, 0.0; 1.0, 0.0, 0.0; 0.5, 1.0, 0.0]
        );
        assert_eq!(l.a(), &dmatrix![0.125]);
        assert_eq!(l.c(), &dmatrix![1.0; 0.5; 0.25]);
        assert_eq!(l.b(), &dmatrix![0.25, 0.5, 1.0]);
        assert!(matches!(lift(&s, 0), Err(Error::InvalidArgument { .. })));
    }
}
