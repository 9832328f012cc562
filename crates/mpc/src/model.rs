//! Model checks and the quantities both predictors need: step-response
//! coefficients S_i of P_T/Δ (8.6) and the realisation (A_I, B_I, C_I) of
//! P_T/Δ driven by Δu (8.10).

use lifted_lti::StateSpace;
use nalgebra::DMatrix;

use crate::error::{Error, Result};

/// Checks that `sys` is a discrete, strictly proper (D = 0) model with at
/// least one input and output; returns (p, m).
pub(crate) fn check_model(what: &'static str, sys: &StateSpace) -> Result<(usize, usize)> {
    check_discrete(what, sys)?;
    if sys.d().amax() != 0.0 {
        return Err(Error::InvalidModel {
            what,
            reason: "must be strictly proper (D = 0; the thesis model P_T(q⁻¹) has a delay): \
                     identify it with D fixed at zero (`lifted identify --feedthrough false`, \
                     Python `feedthrough=False`)"
                .into(),
        });
    }
    Ok((sys.n_outputs(), sys.n_inputs()))
}

/// A discrete model with at least one input and one output.
pub(crate) fn check_discrete(what: &'static str, sys: &StateSpace) -> Result<()> {
    discrete_ts(what, sys)?;
    if sys.n_inputs() == 0 || sys.n_outputs() == 0 {
        return Err(Error::InvalidModel {
            what,
            reason: "needs at least one input and one output".into(),
        });
    }
    Ok(())
}

/// The sample time of a discrete model, [`Error::InvalidModel`] otherwise.
pub(crate) fn discrete_ts(what: &'static str, sys: &StateSpace) -> Result<f64> {
    sys.ts().ok_or_else(|| Error::InvalidModel {
        what,
        reason: "must be discrete-time".into(),
    })
}

/// Step-response coefficients S_0 = 0, S_i = Σ_{k<i} C Aᵏ B (i = 1 … count)
/// of a strictly proper model: the a_i of P_T/Δ (8.6), p×m each. O(count n²m).
///
/// Errors: [`Error::InvalidModel`] (continuous, not strictly proper).
pub fn step_coefficients(sys: &StateSpace, count: usize) -> Result<Vec<DMatrix<f64>>> {
    let (p, m) = check_model("model", sys)?;
    let mut out = Vec::with_capacity(count + 1);
    out.push(DMatrix::zeros(p, m));
    let mut ak_b = sys.b().clone();
    let mut acc = DMatrix::zeros(p, m);
    for _ in 0..count {
        acc += sys.c() * &ak_b;
        out.push(acc.clone());
        ak_b = sys.a() * ak_b;
    }
    Ok(out)
}

/// Realisation of P_T/Δ with input Δu (8.10): x_d = [x; u(k−1)],
/// A_I = [A B; 0 I], B_I = [B; I], C_I = [C 0].
pub fn integrated_model(sys: &StateSpace) -> Result<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)> {
    let (p, m) = check_model("model", sys)?;
    let n = sys.order();
    let mut ai = DMatrix::zeros(n + m, n + m);
    ai.view_mut((0, 0), (n, n)).copy_from(sys.a());
    ai.view_mut((0, n), (n, m)).copy_from(sys.b());
    ai.view_mut((n, n), (m, m)).fill_with_identity();
    let mut bi = DMatrix::zeros(n + m, m);
    bi.view_mut((0, 0), (n, m)).copy_from(sys.b());
    bi.view_mut((n, 0), (m, m)).fill_with_identity();
    let mut ci = DMatrix::zeros(p, n + m);
    ci.view_mut((0, 0), (p, n)).copy_from(sys.c());
    Ok((ai, bi, ci))
}

/// The model seen at the slow rate n T with the input held n samples
/// (A^n, Σ_{i<n} Aⁱ B, C, D; sample time n·T): the model of the slow
/// single-rate MPC that Chapter 8 compares against. O(n·order³).
///
/// Errors: `n = 0`, model errors.
pub fn hold_model(sys: &StateSpace, n: usize) -> Result<StateSpace> {
    crate::error::check_at_least_one("slow period n", n)?;
    let ts = discrete_ts("model", sys)?;
    let order = sys.order();
    let mut an = DMatrix::identity(order, order);
    let mut bn = DMatrix::zeros(order, sys.n_inputs());
    for _ in 0..n {
        bn += &an * sys.b();
        an = sys.a() * an;
    }
    Ok(StateSpace::new(
        an,
        bn,
        sys.c().clone(),
        sys.d().clone(),
        Some(ts * n as f64),
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::dmatrix;

    #[test]
    fn step_coefficients_of_first_order() {
        let s = StateSpace::new(
            dmatrix![0.5],
            dmatrix![1.0],
            dmatrix![1.0],
            dmatrix![0.0],
            Some(1.0),
        )
        .unwrap();
        let a = step_coefficients(&s, 3).unwrap();
        let v: Vec<f64> = a.iter().map(|m| m[(0, 0)]).collect();
        assert_eq!(v, vec![0.0, 1.0, 1.5, 1.75]);
        let h = hold_model(&s, 2).unwrap();
        assert_eq!(h.a(), &dmatrix![0.25]);
        assert_eq!(h.b(), &dmatrix![1.5]);
        assert_eq!(h.ts(), Some(2.0));
    }
}
