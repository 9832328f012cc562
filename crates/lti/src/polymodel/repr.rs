//! The JSON form of [`PolyModel`] (see its type docs): validated on reading
//! by [`PolyModel::new`].

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use super::{PolyModel, Polynomials};
use crate::error::{Error, Result};

/// Serde representation: polynomial matrices as nested arrays, matrices as
/// arrays of rows.
#[derive(Serialize, Deserialize)]
pub(super) struct PolyRepr {
    ts: f64,
    #[serde(default)]
    a: Option<Vec<Vec<Vec<f64>>>>,
    b: Vec<Vec<Vec<f64>>>,
    #[serde(default)]
    c: Option<Vec<Vec<f64>>>,
    #[serde(default)]
    d: Option<Vec<Vec<f64>>>,
    #[serde(default)]
    f: Option<Vec<Vec<Vec<f64>>>>,
    nk: Vec<Vec<usize>>,
    #[serde(default)]
    noise_variance: Option<Vec<Vec<f64>>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    covariance: Option<Vec<Vec<f64>>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    input_names: Option<Vec<String>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    output_names: Option<Vec<String>>,
}

fn rows_of(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    m.row_iter().map(|r| r.iter().copied().collect()).collect()
}

fn square(what: &'static str, rows: &[Vec<f64>]) -> Result<DMatrix<f64>> {
    let n = rows.len();
    if rows.iter().any(|r| r.len() != n) {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("{n} rows of {n} entries"),
            got: format!(
                "rows of {:?} entries",
                rows.iter().map(Vec::len).collect::<Vec<_>>()
            ),
        });
    }
    Ok(DMatrix::from_fn(n, n, |i, j| rows[i][j]))
}

impl From<PolyModel> for PolyRepr {
    fn from(m: PolyModel) -> Self {
        let p = m.polynomials();
        Self {
            ts: m.ts,
            a: p.a,
            b: p.b,
            c: p.c,
            d: p.d,
            f: p.f,
            nk: p.nk,
            noise_variance: Some(rows_of(&m.noise_variance)),
            covariance: m.covariance.as_ref().map(rows_of),
            input_names: m.input_names,
            output_names: m.output_names,
        }
    }
}

impl TryFrom<PolyRepr> for PolyModel {
    type Error = Error;
    fn try_from(r: PolyRepr) -> Result<Self> {
        let p = Polynomials {
            a: r.a,
            b: r.b,
            c: r.c,
            d: r.d,
            f: r.f,
            nk: r.nk,
        };
        let mut m = PolyModel::new(p, r.ts)?;
        if let Some(rows) = r.noise_variance {
            m = m.with_noise_variance(&square("noise variance", &rows)?)?;
        }
        if let Some(rows) = r.covariance {
            m = m.with_covariance(&square("parameter covariance", &rows)?)?;
        }
        if let Some(names) = r.input_names {
            m = m.with_input_names(names)?;
        }
        if let Some(names) = r.output_names {
            m = m.with_output_names(names)?;
        }
        Ok(m)
    }
}

impl PolyModel {
    /// Serialises to JSON (the layout of the type docs). O(r + n_par²).
    ///
    /// Errors: [`Error::Json`] (not expected for a valid model).
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string(self).map_err(|e| Error::Json {
            reason: e.to_string(),
        })
    }

    /// Parses and validates a JSON model (every check of
    /// [`PolyModel::new`], [`PolyModel::with_noise_variance`] and
    /// [`PolyModel::with_covariance`]).
    ///
    /// Errors: [`Error::Json`] with serde's message (the validation error
    /// included).
    pub fn from_json(s: &str) -> Result<Self> {
        serde_json::from_str(s).map_err(|e| Error::Json {
            reason: e.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{coupled_arx, siso_models};
    use super::*;

    #[test]
    fn json_round_trip_keeps_everything() {
        let cov = DMatrix::from_fn(
            9,
            9,
            |i, j| if i == j { 0.01 * (i + 1) as f64 } else { 0.0 },
        );
        let lam = DMatrix::from_row_slice(2, 2, &[1.0, 0.3, 0.3, 2.0]);
        let m = coupled_arx()
            .with_covariance(&cov)
            .and_then(|m| m.with_noise_variance(&lam))
            .and_then(|m| m.with_output_names(vec!["y1".into(), "y2".into()]))
            .unwrap();
        let back = PolyModel::from_json(&m.to_json().unwrap()).unwrap();
        assert_eq!(back, m);
        assert_eq!(back.std().unwrap()[2], 0.03f64.sqrt());
        for m in siso_models() {
            assert_eq!(PolyModel::from_json(&m.to_json().unwrap()).unwrap(), m);
        }
    }

    #[test]
    fn json_defaults_and_rejections() {
        let m = PolyModel::from_json(r#"{"ts": 1, "b": [[[1, 0.5]]], "nk": [[1]]}"#).unwrap();
        assert_eq!(m, PolyModel::fir(&[1.0, 0.5], 1, 1.0).unwrap());
        let bad = r#"{"ts": 1, "a": [[[2, 0.5]]], "b": [[[1]]], "nk": [[1]]}"#;
        let e = PolyModel::from_json(bad).unwrap_err().to_string();
        assert!(e.contains("must start with 1"), "{e}");
        let bad_ts = r#"{"ts": -1, "b": [[[1]]], "nk": [[1]]}"#;
        assert!(PolyModel::from_json(bad_ts).is_err());
        let bad_cov = r#"{"ts": 1, "b": [[[1]]], "nk": [[1]], "covariance": [[1, 0]]}"#;
        assert!(PolyModel::from_json(bad_cov).is_err());
    }
}
