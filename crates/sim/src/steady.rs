//! Periodic steady state of a periodically excited loop (PRBS experiments).

use nalgebra::{DMatrix, DVector};

use crate::engine::{Engine, RunInput};
use crate::error::{Error, Result};
use crate::simulator::{Excitation, SimOutput, Simulator};

/// Which periodicity the iterative method checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PeriodicityCheck {
    /// y(k) ≈ −y(k + P/2) within one period P (inverse PRBS, Zhu 2000 IV.B
    /// and erratum Z-12: y(k) = −y(k + n_r m)). The default.
    #[default]
    Antisymmetric,
    /// y(k) ≈ y(k + P) between consecutive periods.
    Periodic,
}

/// How to reach the periodic steady state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SteadyStateMethod {
    /// Exact (spec pitfall 7): the one-period map z ↦ Φz + f of the whole
    /// simulator state is built by simulation (one period per state
    /// component), then z₀ = (I − Φ)⁻¹ f. Fails with
    /// [`Error::UnstableLoop`] when the spectral radius of Φ is ≥ 1.
    /// Cost O(n_z · P · step + n_z³).
    Exact,
    /// Run period after period from rest until the check holds to
    /// `tolerance` (relative to max |y|), at most `max_periods` periods.
    Iterate {
        /// Relative tolerance of the check.
        tolerance: f64,
        /// Maximum number of periods.
        max_periods: usize,
        /// Which check.
        check: PeriodicityCheck,
    },
}

/// Options of [`Simulator::periodic_steady_state`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteadyStateOptions {
    /// Method; default [`SteadyStateMethod::Exact`].
    pub method: SteadyStateMethod,
    /// Check used for the reported residual; default antisymmetric.
    pub check: PeriodicityCheck,
}

impl Default for SteadyStateOptions {
    fn default() -> Self {
        SteadyStateOptions {
            method: SteadyStateMethod::Exact,
            check: PeriodicityCheck::Antisymmetric,
        }
    }
}

impl SteadyStateOptions {
    /// The iterative method with tolerance 1e-9 (spec pitfall 7), at most
    /// 1000 periods, antisymmetric check.
    pub fn iterate(tolerance: f64) -> Self {
        let check = PeriodicityCheck::Antisymmetric;
        SteadyStateOptions {
            method: SteadyStateMethod::Iterate {
                tolerance,
                max_periods: 1000,
                check,
            },
            check,
        }
    }
}

/// One period of the periodic steady state.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyState {
    /// Exactly one period, starting in the steady state (noise added if configured).
    pub output: SimOutput,
    /// Periods simulated from rest before the check held (iterative method);
    /// None for the exact method.
    pub periods: Option<usize>,
    /// Residual of the periodicity check on the noise-free response,
    /// relative to max |y|: antisymmetry max|y(k) + y(k+P/2)| within the
    /// returned period, or max|y(k+P) − y(k)| over the next period.
    pub residual: f64,
    /// Simulator state at the start of the period (layout:
    /// [`crate::Simulator::state_layout`]).
    pub initial_state: Vec<f64>,
}

impl Simulator {
    /// The periodic steady state for an excitation given over **one period**
    /// P (its length), which must be a multiple of the hold/sampling
    /// pattern's period. Returns exactly one period.
    ///
    /// Errors: [`Error::PeriodMismatch`], [`Error::OddPeriod`] (antisymmetric
    /// check), [`Error::UnstableLoop`], [`Error::NotPeriodic`], and those of
    /// [`Simulator::simulate`].
    pub fn periodic_steady_state(
        &self,
        one_period: &Excitation,
        opts: &SteadyStateOptions,
    ) -> Result<SteadyState> {
        let p = self.check_excitation(one_period)?;
        let engine = self.engine()?;
        if p % engine.frame != 0 {
            return Err(Error::PeriodMismatch {
                period: p,
                frame: engine.frame,
            });
        }
        let checks = [
            opts.check,
            if let SteadyStateMethod::Iterate { check, .. } = opts.method {
                check
            } else {
                opts.check
            },
        ];
        if checks.contains(&PeriodicityCheck::Antisymmetric) && p % 2 != 0 {
            return Err(Error::OddPeriod { period: p });
        }
        let inp = RunInput {
            r1: one_period.r1.as_ref(),
            r2: one_period.r2.as_ref(),
            noise: None,
            len: p,
        };
        let (z0, periods) = match opts.method {
            SteadyStateMethod::Exact => (exact_state(&engine, &inp)?, None),
            SteadyStateMethod::Iterate {
                tolerance,
                max_periods,
                check,
            } => {
                if !(tolerance > 0.0 && tolerance.is_finite()) {
                    return Err(Error::NonFinite {
                        what: "steady-state tolerance",
                        value: tolerance,
                    });
                }
                let mut z = vec![0.0; engine.nz];
                let mut prev: Option<DMatrix<f64>> = None;
                let mut found = None;
                let mut residual = f64::INFINITY;
                for period in 1..=max_periods {
                    let mut rec = blank(p, self.nu, self.ny);
                    let zn = engine.run(&z, &inp, Some(&mut rec))?;
                    residual = match check {
                        PeriodicityCheck::Antisymmetric => antisymmetry(&rec.y_clean),
                        PeriodicityCheck::Periodic => prev
                            .as_ref()
                            .map_or(f64::INFINITY, |q| periodicity(q, &rec.y_clean)),
                    };
                    if residual <= tolerance {
                        found = Some((z.clone(), period));
                        break;
                    }
                    prev = Some(rec.y_clean);
                    z = zn;
                }
                match found {
                    Some((z0, n)) => (z0, Some(n)),
                    None => {
                        return Err(Error::NotPeriodic {
                            periods: max_periods,
                            residual,
                            tolerance,
                        });
                    }
                }
            }
        };
        // residual on the noise-free response from z0
        let mut rec = blank(p, self.nu, self.ny);
        let z1 = engine.run(&z0, &inp, Some(&mut rec))?;
        let residual = match opts.check {
            PeriodicityCheck::Antisymmetric => antisymmetry(&rec.y_clean),
            PeriodicityCheck::Periodic => {
                let mut rec2 = blank(p, self.nu, self.ny);
                engine.run(&z1, &inp, Some(&mut rec2))?;
                periodicity(&rec.y_clean, &rec2.y_clean)
            }
        };
        let output = self.run_from(&engine, &z0, one_period)?;
        Ok(SteadyState {
            output,
            periods,
            residual,
            initial_state: z0,
        })
    }
}

fn blank(p: usize, nu: usize, ny: usize) -> crate::engine::Record {
    crate::engine::Record {
        u: DMatrix::zeros(p, nu),
        y: DMatrix::zeros(p, ny),
        y_clean: DMatrix::zeros(p, ny),
    }
}

fn exact_state(engine: &Engine, inp: &RunInput<'_>) -> Result<Vec<f64>> {
    let nz = engine.nz;
    let zero_inp = RunInput {
        r1: None,
        r2: None,
        noise: None,
        len: inp.len,
    };
    let mut phi = DMatrix::zeros(nz, nz);
    let mut e = vec![0.0; nz];
    for i in 0..nz {
        e.iter_mut().for_each(|v| *v = 0.0);
        e[i] = 1.0;
        let col = engine.run(&e, &zero_inp, None)?;
        phi.column_mut(i).copy_from_slice(&col);
    }
    let f = engine.run(&vec![0.0; nz], inp, None)?;
    if nz == 0 {
        return Ok(Vec::new());
    }
    let rho = lifted_linalg::eigenvalues(&phi)?
        .iter()
        .map(|l| l.norm())
        .fold(0.0, f64::max);
    if rho >= 1.0 - 1e-12 {
        return Err(Error::UnstableLoop {
            spectral_radius: rho,
        });
    }
    let lhs = DMatrix::<f64>::identity(nz, nz) - &phi;
    let z0 = lifted_linalg::solve(&lhs, &DMatrix::from_column_slice(nz, 1, &f))?;
    Ok(DVector::from_column_slice(z0.as_slice())
        .as_slice()
        .to_vec())
}

fn max_abs(m: &DMatrix<f64>) -> f64 {
    m.iter().fold(0.0f64, |a, v| a.max(v.abs()))
}

/// max_k |y(k) + y(k + P/2)| / max |y| within one period.
pub(crate) fn antisymmetry(y: &DMatrix<f64>) -> f64 {
    let (p, ny) = y.shape();
    let h = p / 2;
    let scale = max_abs(y).max(f64::MIN_POSITIVE);
    let mut r = 0.0f64;
    for j in 0..ny {
        for k in 0..h {
            r = r.max((y[(k, j)] + y[(k + h, j)]).abs());
        }
    }
    r / scale
}

/// max |a − b| / max |b|.
pub(crate) fn periodicity(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    let scale = max_abs(b).max(f64::MIN_POSITIVE);
    a.iter()
        .zip(b.iter())
        .fold(0.0f64, |r, (x, y)| r.max((x - y).abs()))
        / scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn residual_measures() {
        let y = DMatrix::from_column_slice(4, 1, &[1.0, 2.0, -1.0, -2.0]);
        assert_eq!(antisymmetry(&y), 0.0);
        let y2 = DMatrix::from_column_slice(4, 1, &[1.0, 2.0, -1.0, -1.0]);
        assert!((antisymmetry(&y2) - 0.5).abs() < 1e-15);
        assert!((periodicity(&y, &y2) - 0.5).abs() < 1e-15);
    }
}
