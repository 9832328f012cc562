//! Lifted state-space models from a fast model (thesis Prop. 1, eq. 4.5–4.7;
//! Prop. 4, eq. 5.4; §3.1 slow hold; lifted noise models) and the
//! observability analysis of §4.3 (Prop. 2).
//!
//! For a fast model (A, B, C, D) at the base period T and a lifting with
//! frame J, input slot (c, s) held on [t, t + m_c) and output slot (o, r)
//! at τ, the lifted model is
//!
//! * Ā = A^J,
//! * B̄ column (c, s) = Σ_{t'=t}^{t+m_c−1} A^{J−1−t'} B_c,
//! * C̄ row (o, r) = C_o A^τ,
//! * D̄ entry = Σ_{t ≤ t' < min(t+m_c, τ)} C_o A^{τ−1−t'} B_c + D_{oc}·[t ≤ τ < t + m_c].
//!
//! For SISO hold mT, sampling nT this is Prop. 1 with the general D̄ entry
//! of spec A3.2 (erratum L-5: the printed (1,1) entry is the case n < 2m);
//! with holds T and outputs every J_i T it is Prop. 4 with the subscripts of
//! erratum L-13. Cost O(J n³ + J n² (n_u + n_y)).

use lifted_linalg::{RankTolerance, rank, singular_values};
use lifted_lti::StateSpace;
use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::error::{Error, Result};
use crate::lifting::{MultirateLifting, SisoRates};

fn discrete_ts(fast: &StateSpace, what: &'static str) -> Result<f64> {
    fast.ts().ok_or(Error::Unsupported {
        what,
        reason: "the fast model must be discrete (ts = base period T)".into(),
    })
}

/// The lifted model of `fast` (base period T) for `lifting` (see the
/// [module docs](self)); its sample period is J·T. Errors: continuous
/// model, channel counts that differ from the lifting's.
pub fn lift_model(fast: &StateSpace, lifting: &MultirateLifting) -> Result<StateSpace> {
    let ts = discrete_ts(fast, "lift_model")?;
    if fast.n_inputs() != lifting.n_inputs() || fast.n_outputs() != lifting.n_outputs() {
        return Err(Error::DimensionMismatch {
            what: "fast model channels",
            expected: format!(
                "{} inputs, {} outputs",
                lifting.n_inputs(),
                lifting.n_outputs()
            ),
            got: format!("{} inputs, {} outputs", fast.n_inputs(), fast.n_outputs()),
        });
    }
    let (a, b, c, d) = (fast.a(), fast.b(), fast.c(), fast.d());
    let n = a.nrows();
    let j = lifting.period();
    // powers A^0 … A^J
    let mut pw = Vec::with_capacity(j + 1);
    pw.push(DMatrix::<f64>::identity(n, n));
    for k in 0..j {
        let next = a * &pw[k];
        pw.push(next);
    }
    // CA^k B for all channels: markov(k) = C A^{k} B (n_y × n_u), k < J
    let markov: Vec<DMatrix<f64>> = (0..j).map(|k| c * &pw[k] * b).collect();
    let ins = lifting.input_slots();
    let outs = lifting.output_slots();
    let holds = lifting.holds();
    let mut bl = DMatrix::zeros(n, ins.len());
    for (col, s) in ins.iter().enumerate() {
        let h = holds[s.channel];
        for tp in s.time..s.time + h {
            let v = &pw[j - 1 - tp] * b.column(s.channel);
            let mut dst = bl.column_mut(col);
            dst += v;
        }
    }
    let mut cl = DMatrix::zeros(outs.len(), n);
    for (row, o) in outs.iter().enumerate() {
        let r = c.row(o.channel) * &pw[o.time];
        cl.row_mut(row).copy_from(&r);
    }
    let mut dl = DMatrix::zeros(outs.len(), ins.len());
    for (row, o) in outs.iter().enumerate() {
        for (col, s) in ins.iter().enumerate() {
            let h = holds[s.channel];
            let tau = o.time;
            let mut v = 0.0;
            for tp in s.time..(s.time + h).min(tau) {
                v += markov[tau - 1 - tp][(o.channel, s.channel)];
            }
            if s.time <= tau && tau < s.time + h {
                v += d[(o.channel, s.channel)];
            }
            dl[(row, col)] = v;
        }
    }
    Ok(StateSpace::new(
        pw[j].clone(),
        bl,
        cl,
        dl,
        Some(ts * j as f64),
    )?)
}

/// Prop. 1 (eq. 4.5): the lifted model of a SISO fast model for hold mT
/// and sampling nT (co-prime), ordering of the thesis.
pub fn siso_lifted_model(fast: &StateSpace, rates: SisoRates) -> Result<StateSpace> {
    lift_model(fast, &MultirateLifting::siso(rates)?)
}

/// The single-rate lifting L_f G L_f⁻¹ of a model (eq. 4.6; with m = 1 and
/// one output sample per frame this is eq. 4.7 — use [`lift_model`] with
/// [`MultirateLifting::mimo`] for that). Used for the lifted noise model of
/// §4.2: N̲ = L_m N_{nT} L_m⁻¹ is `lift_single_rate(n_nt, m)` where `n_nt`
/// is the noise model discretised at nT; MIMO diagonal noise models (§5.2)
/// are [`lifted_lti::append`] of the per-channel liftings.
pub fn lift_single_rate(model: &StateSpace, factor: usize) -> Result<StateSpace> {
    let l = MultirateLifting::uniform(
        factor,
        model.n_inputs(),
        model.n_outputs(),
        crate::lifting::Ordering::ChannelMajor,
    )?;
    lift_model(model, &l)
}

/// Observability of a (lifted) model: rank of [C; CA; …; CA^{n−1}].
#[derive(Debug, Clone, PartialEq)]
pub struct ObservabilityReport {
    /// Model order n.
    pub order: usize,
    /// Numerical rank of the observability matrix.
    pub rank: usize,
    /// Its singular values, descending.
    pub singular_values: Vec<f64>,
}

impl ObservabilityReport {
    /// rank = order.
    pub fn is_observable(&self) -> bool {
        self.rank == self.order
    }
}

/// Rank of the observability matrix with a relative tolerance `rel_tol`
/// (σ > rel_tol·σ_max counts; 1e-10 is a good choice for exact models).
/// O(n³ n_y). The thesis' Condition 1 is only sufficient and fails for any
/// zero eigenvalue of A, so observability is decided by rank (spec A3.3).
pub fn observability(model: &StateSpace, rel_tol: f64) -> Result<ObservabilityReport> {
    let n = model.order();
    let (a, c) = (model.a(), model.c());
    let p = c.nrows();
    let mut o = DMatrix::zeros(p * n.max(1), n);
    let mut blk = c.clone();
    for k in 0..n {
        o.rows_mut(k * p, p).copy_from(&blk);
        blk = &blk * a;
    }
    if n == 0 {
        return Ok(ObservabilityReport {
            order: 0,
            rank: 0,
            singular_values: vec![],
        });
    }
    let r = rank(&o, RankTolerance::Relative(rel_tol))?;
    let s = singular_values(&o)?;
    Ok(ObservabilityReport {
        order: n,
        rank: r,
        singular_values: s.iter().cloned().collect(),
    })
}

/// Condition 1 of thesis §4.3 for the frame J = mn: no eigenvalue λ of A
/// has λe^{2πik/J} (k = 1…J−1) as another eigenvalue (relative tolerance
/// `tol`). Sufficient, not necessary: a simple zero eigenvalue violates it
/// without destroying observability (spec A3.3), so use
/// [`observability`] for the decision.
pub fn condition_one(a: &DMatrix<f64>, frame: usize, tol: f64) -> Result<bool> {
    let ev = lifted_linalg::eigenvalues(a)?;
    for (i, l) in ev.iter().enumerate() {
        for k in 1..frame {
            let rot = l * Complex64::from_polar(
                1.0,
                2.0 * std::f64::consts::PI * k as f64 / frame as f64,
            );
            for (jj, mu) in ev.iter().enumerate() {
                // the eigenvalue itself counts when it is zero (rot = l) or a
                // different eigenvalue matches
                if (rot - mu).norm() <= tol * mu.norm().max(1.0) && (jj != i || l.norm() <= tol) {
                    return Ok(false);
                }
            }
        }
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fast() -> StateSpace {
        StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.5, 0.2, -0.1, 0.3]),
            DMatrix::from_row_slice(2, 1, &[1.0, 0.5]),
            DMatrix::from_row_slice(1, 2, &[1.0, -1.0]),
            DMatrix::from_element(1, 1, 0.25),
            Some(1.0),
        )
        .unwrap()
    }

    #[test]
    fn m_equal_one_is_eq_4_7() {
        let g = fast();
        let l = lift_model(
            &g,
            &MultirateLifting::siso(SisoRates::new(1, 3).unwrap()).unwrap(),
        )
        .unwrap();
        let a = g.a();
        assert!((l.a() - a * a * a).norm() < 1e-14);
        assert!((l.b().column(0) - a * a * g.b()).norm() < 1e-14);
        assert!((l.b().column(2) - g.b()).norm() < 1e-14);
        assert_eq!(l.d()[(0, 0)], 0.25);
        assert_eq!(l.d()[(0, 1)], 0.0);
        assert_eq!(l.ts(), Some(3.0));
    }

    #[test]
    fn condition_one_fails_for_zero_eigenvalues() {
        let a = DMatrix::from_row_slice(2, 2, &[0.9, 0.0, 1.0, 0.0]);
        assert!(!condition_one(&a, 3, 1e-12).unwrap());
        let a = DMatrix::from_row_slice(2, 2, &[0.9, 0.0, 0.0, 0.5]);
        assert!(condition_one(&a, 3, 1e-12).unwrap());
    }
}
