//! The state-space model (A, B, C, D) in continuous or discrete time.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_ts};
use crate::la;

/// A linear time-invariant state-space model
///
/// continuous: ẋ = A x + B u, y = C x + D u (`ts == None`);
/// discrete:   x(k+1) = A x(k) + B u(k), y(k) = C x(k) + D u(k) (`ts == Some(T)`).
///
/// Shapes: A n×n, B n×m, C p×n, D p×m. The fields are private so every
/// model has been validated (finite entries, consistent shapes, positive
/// finite `ts`). Serialises to JSON as `{"a": [[..],..], "b", "c", "d",
/// "ts": null | T, "input_names"?, "output_names"?}` with matrices as arrays
/// of rows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "SsRepr", into = "SsRepr")]
pub struct StateSpace {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    d: DMatrix<f64>,
    pub(crate) ts: Option<f64>,
    pub(crate) input_names: Option<Vec<String>>,
    pub(crate) output_names: Option<Vec<String>>,
}

impl StateSpace {
    /// Validates and builds a model; `ts = None` is continuous time.
    ///
    /// Errors: non-finite entries ([`lifted_linalg::Error::NonFinite`]),
    /// non-square A ([`lifted_linalg::Error::NotSquare`]), B rows ≠ n, C
    /// columns ≠ n, D not p×m ([`lifted_linalg::Error::DimensionMismatch`],
    /// wrapped in [`Error::Linalg`]), invalid `ts` ([`Error::InvalidSamplePeriod`]).
    pub fn new(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
        ts: Option<f64>,
    ) -> Result<Self> {
        let n = la::check_square("A", &a)?;
        la::check_rows("B", &b, n)?;
        la::check_cols("C", &c, n)?;
        la::check_rows("D", &d, c.nrows())?;
        la::check_cols("D", &d, b.ncols())?;
        for (what, m) in [("A", &a), ("B", &b), ("C", &c), ("D", &d)] {
            la::check_finite(what, m)?;
        }
        check_ts(ts)?;
        Ok(Self {
            a,
            b,
            c,
            d,
            ts,
            input_names: None,
            output_names: None,
        })
    }

    /// A static gain y = D u (no states).
    pub fn gain(d: DMatrix<f64>, ts: Option<f64>) -> Result<Self> {
        let (p, m) = d.shape();
        Self::new(
            DMatrix::zeros(0, 0),
            DMatrix::zeros(0, m),
            DMatrix::zeros(p, 0),
            d,
            ts,
        )
    }

    /// Builds without validation (internal: inputs are produced by this crate).
    pub(crate) fn from_parts(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
        ts: Option<f64>,
    ) -> Self {
        debug_assert_eq!(a.nrows(), a.ncols());
        debug_assert_eq!(b.nrows(), a.nrows());
        debug_assert_eq!(c.ncols(), a.nrows());
        debug_assert_eq!(d.shape(), (c.nrows(), b.ncols()));
        Self {
            a,
            b,
            c,
            d,
            ts,
            input_names: None,
            output_names: None,
        }
    }

    /// Attaches input names (one per input).
    pub fn with_input_names(mut self, names: Vec<String>) -> Result<Self> {
        if names.len() != self.n_inputs() {
            return Err(Error::DimensionMismatch {
                what: "input names",
                expected: format!("{} names", self.n_inputs()),
                got: format!("{} names", names.len()),
            });
        }
        self.input_names = Some(names);
        Ok(self)
    }

    /// Attaches output names (one per output).
    pub fn with_output_names(mut self, names: Vec<String>) -> Result<Self> {
        if names.len() != self.n_outputs() {
            return Err(Error::DimensionMismatch {
                what: "output names",
                expected: format!("{} names", self.n_outputs()),
                got: format!("{} names", names.len()),
            });
        }
        self.output_names = Some(names);
        Ok(self)
    }

    /// State matrix A (n×n).
    pub fn a(&self) -> &DMatrix<f64> {
        &self.a
    }
    /// Input matrix B (n×m).
    pub fn b(&self) -> &DMatrix<f64> {
        &self.b
    }
    /// Output matrix C (p×n).
    pub fn c(&self) -> &DMatrix<f64> {
        &self.c
    }
    /// Feedthrough D (p×m).
    pub fn d(&self) -> &DMatrix<f64> {
        &self.d
    }
    /// Sample period (None: continuous time).
    pub fn ts(&self) -> Option<f64> {
        self.ts
    }
    /// True for discrete-time models.
    pub fn is_discrete(&self) -> bool {
        self.ts.is_some()
    }
    /// Number of states n.
    pub fn order(&self) -> usize {
        self.a.nrows()
    }
    /// Number of inputs m.
    pub fn n_inputs(&self) -> usize {
        self.b.ncols()
    }
    /// Number of outputs p.
    pub fn n_outputs(&self) -> usize {
        self.c.nrows()
    }
    /// Input names, if set.
    pub fn input_names(&self) -> Option<&[String]> {
        self.input_names.as_deref()
    }
    /// Output names, if set.
    pub fn output_names(&self) -> Option<&[String]> {
        self.output_names.as_deref()
    }

    /// The similar model with x = T z: (T⁻¹AT, T⁻¹B, CT, D). O(n³).
    ///
    /// Errors: T not n×n or not finite; T singular ([`Error::Linalg`] `Singular`).
    pub fn similarity_transform(&self, t: &DMatrix<f64>) -> Result<Self> {
        let n = la::check_square("T", t)?;
        la::check_rows("T", t, self.order())?;
        la::check_finite("T", t)?;
        let ti = la::inv(t)?;
        let _ = n;
        let mut out = Self::from_parts(
            &ti * &self.a * t,
            &ti * &self.b,
            &self.c * t,
            self.d.clone(),
            self.ts,
        );
        out.input_names.clone_from(&self.input_names);
        out.output_names.clone_from(&self.output_names);
        Ok(out)
    }

    /// Serialises to JSON (see the type docs for the layout).
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string(self).map_err(|e| Error::Json {
            reason: e.to_string(),
        })
    }

    /// Parses and validates a JSON model.
    pub fn from_json(s: &str) -> Result<Self> {
        serde_json::from_str(s).map_err(|e| Error::Json {
            reason: json_reason(&e),
        })
    }
}

/// JSON representation: matrices as arrays of rows.
#[derive(Serialize, Deserialize)]
struct SsRepr {
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    c: Vec<Vec<f64>>,
    d: Vec<Vec<f64>>,
    // Required, null for a continuous-time model: a file whose `ts` was
    // dropped or misspelt loaded as continuous time without a word.
    #[serde(deserialize_with = "required_ts")]
    ts: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    input_names: Option<Vec<String>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    output_names: Option<Vec<String>>,
}

/// serde's message, with what a missing `ts` means.
pub(crate) fn json_reason(e: &serde_json::Error) -> String {
    let msg = e.to_string();
    if msg.contains("missing field `ts`") {
        format!("{msg} (the sample period in seconds, or null for a continuous-time model)")
    } else {
        msg
    }
}

/// `ts` as written (a number, or null for continuous time); its absence is
/// an error (serde's "missing field `ts`").
fn required_ts<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<f64>, D::Error> {
    Option::<f64>::deserialize(d)
}

fn rows_of(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

fn from_rows(what: &'static str, rows: &[Vec<f64>], ncols_if_empty: usize) -> Result<DMatrix<f64>> {
    let r = rows.len();
    let c = rows.first().map_or(ncols_if_empty, Vec::len);
    if let Some(bad) = rows.iter().find(|row| row.len() != c) {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("rows of length {c}"),
            got: format!("a row of length {}", bad.len()),
        });
    }
    Ok(DMatrix::from_fn(r, c, |i, j| rows[i][j]))
}

impl From<StateSpace> for SsRepr {
    fn from(s: StateSpace) -> Self {
        Self {
            a: rows_of(&s.a),
            b: rows_of(&s.b),
            c: rows_of(&s.c),
            d: rows_of(&s.d),
            ts: s.ts,
            input_names: s.input_names,
            output_names: s.output_names,
        }
    }
}

impl TryFrom<SsRepr> for StateSpace {
    type Error = Error;
    fn try_from(r: SsRepr) -> Result<Self> {
        let a = from_rows("a", &r.a, r.a.len())?;
        let n = a.nrows();
        // With no states, B is 0×m and C is p×0: recover m and p from D.
        let m = if n > 0 {
            r.b.first().map_or(0, Vec::len)
        } else {
            r.d.first().map_or(0, Vec::len)
        };
        let b = from_rows("b", &r.b, m)?;
        let c = from_rows("c", &r.c, n)?;
        let d = from_rows("d", &r.d, b.ncols())?;
        let mut s = StateSpace::new(a, b, c, d, r.ts)?;
        if let Some(names) = r.input_names {
            s = s.with_input_names(names)?;
        }
        if let Some(names) = r.output_names {
            s = s.with_output_names(names)?;
        }
        Ok(s)
    }
}

impl std::fmt::Display for StateSpace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.ts {
            None => writeln!(
                f,
                "continuous-time state space, n = {}, m = {}, p = {}",
                self.order(),
                self.n_inputs(),
                self.n_outputs()
            )?,
            Some(t) => writeln!(
                f,
                "discrete-time state space (T = {t}), n = {}, m = {}, p = {}",
                self.order(),
                self.n_inputs(),
                self.n_outputs()
            )?,
        }
        write!(
            f,
            "A = {}B = {}C = {}D = {}",
            self.a, self.b, self.c, self.d
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sys() -> StateSpace {
        StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.5, 1.0, 0.0, 0.25]),
            DMatrix::from_row_slice(2, 1, &[0.0, 1.0]),
            DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap()
    }

    #[test]
    fn accessors_and_similarity() {
        let s = sys();
        assert_eq!((s.order(), s.n_inputs(), s.n_outputs()), (2, 1, 1));
        assert!(s.is_discrete());
        let t = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 0.0, 1.0]);
        let z = s.similarity_transform(&t).unwrap();
        let h1 = s.markov_parameters(4).unwrap();
        let h2 = z.markov_parameters(4).unwrap();
        for (a, b) in h1.iter().zip(&h2) {
            assert!((a - b).norm() < 1e-14);
        }
        assert!(s.similarity_transform(&DMatrix::zeros(2, 2)).is_err());
    }

    #[test]
    fn names_must_match_channels() {
        assert!(
            sys()
                .with_input_names(vec!["a".into(), "b".into()])
                .is_err()
        );
        let s = sys().with_output_names(vec!["y".into()]).unwrap();
        assert_eq!(s.output_names().unwrap()[0], "y");
    }
}
