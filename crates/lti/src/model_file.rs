//! The model file: a [`StateSpace`] with its provenance, as JSON on disk.
//!
//! Layout (matrices as arrays of rows, `"ts": null` for continuous time):
//!
//! ```json
//! {"kind": "state_space", "ts": 0.01,
//!  "a": [[0.9]], "b": [[0.5]], "c": [[1.0]], "d": [[0.0]],
//!  "input_names": ["u1"], "output_names": ["y1"],
//!  "method": "n4sid", "diagnostics": {"singular_values": [3.1, 0.01]}}
//! ```
//!
//! A polynomial model ([`PolyModel`], kind `"polynomial"`, written by
//! [`ModelFile::with_polynomial`]) is stored as its innovations
//! realisation ([`PolyModel::to_innovations_ss`]: the matrices and
//! `kalman_gain`) **and** the polynomials in a `polynomial` field (the
//! [`PolyModel`] JSON layout, with the noise variance and the parameter
//! covariance), so every reader of state-space model files keeps working
//! and the polynomials survive the round trip:
//!
//! ```json
//! {"kind": "polynomial", "ts": 1.0, "a": [[1.5, 1], [-0.7, 0]], "b": …, "c": …, "d": …,
//!  "kalman_gain": [[…], […]],
//!  "polynomial": {"ts": 1.0, "a": [[[1, -1.5, 0.7]]], "b": [[[1, 0.5]]], "c": [[1]],
//!                 "d": [[1]], "f": [[[1]]], "nk": [[1]], "noise_variance": [[1]]}}
//! ```
//!
//! On reading, a `"polynomial"` file must carry the `polynomial` field (and
//! a `"state_space"` file must not), with the same `ts` and channel counts
//! as the matrices; the matrices are not recomputed.
//!
//! Optional fields: `input_names`, `output_names`, `method`, `diagnostics`,
//! `operating_point` (`{"u0": [...], "y0": [...]}`: the model maps u − u₀
//! to y − y₀; identification stores the means it removed) and
//! `kalman_gain` (rows of the predictor gain K, n × n_y, for k-step-ahead
//! prediction). The matrices are validated exactly as
//! [`StateSpace::new`] does (shapes, finite entries, positive finite `ts`).
//! Reading and writing are O(size of the file).
//!
//! ```
//! use lifted_lti::StateSpace;
//! use lifted_lti::model_file::ModelFile;
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let g = StateSpace::new(
//!     DMatrix::from_element(1, 1, 0.9),
//!     DMatrix::from_element(1, 1, 0.5),
//!     DMatrix::from_element(1, 1, 1.0),
//!     DMatrix::zeros(1, 1),
//!     Some(0.1),
//! )?;
//! let file = ModelFile::new(g.clone()).with_method("n4sid");
//! let json = file.to_json()?;
//! let back = ModelFile::from_json(&json)?;
//! assert_eq!(back.model, g);
//! assert_eq!(back.method.as_deref(), Some("n4sid"));
//! # Ok(())
//! # }
//! ```

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::operating_point::OperatingPoint;
use crate::polymodel::PolyModel;
use crate::ss::StateSpace;
use crate::ss_uncertainty::SsCovariance;
use nalgebra::DMatrix;

/// A gain K of shape order × n_y with finite entries.
fn check_gain(model: &StateSpace, k: &DMatrix<f64>) -> crate::Result<()> {
    if k.shape() != (model.order(), model.n_outputs()) {
        return Err(crate::Error::DimensionMismatch {
            what: "Kalman gain",
            expected: format!("{}x{}", model.order(), model.n_outputs()),
            got: format!("{}x{}", k.nrows(), k.ncols()),
        });
    }
    if let Some(&v) = k.iter().find(|v| !v.is_finite()) {
        return Err(crate::Error::NonFiniteScalar {
            what: "Kalman gain",
            value: v,
        });
    }
    Ok(())
}

/// The `kind` of a state-space model file.
pub const STATE_SPACE_KIND: &str = "state_space";

/// The `kind` of a polynomial model file (state-space matrices plus the
/// `polynomial` field).
pub const POLYNOMIAL_KIND: &str = "polynomial";

/// Errors of [`ModelFile`] reading and writing.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelFileError {
    /// The file could not be read or written.
    #[error("{path}: {reason}")]
    Io {
        /// The file.
        path: String,
        /// The operating-system message.
        reason: String,
    },
    /// The JSON is malformed or the model in it is invalid.
    #[error("{path}: invalid model file: {reason}")]
    Invalid {
        /// The file (`<string>` when parsed from memory).
        path: String,
        /// What is wrong (serde's message, with line and column).
        reason: String,
    },
    /// `kind` is neither `"state_space"` nor `"polynomial"`.
    #[error("{path}: unsupported model kind '{kind}' (expected \"state_space\" or \"polynomial\")")]
    UnsupportedKind {
        /// The file (`<string>` when parsed from memory).
        path: String,
        /// The kind found.
        kind: String,
    },
}

/// A model with its identification method and diagnostics (see the
/// [module docs](self) for the JSON layout).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelFile {
    /// [`STATE_SPACE_KIND`], or [`POLYNOMIAL_KIND`] when `polynomial` is set.
    pub kind: String,
    /// The model (matrices, `ts`, optional channel names), flattened into
    /// the top-level object.
    #[serde(flatten)]
    pub model: StateSpace,
    /// The method that produced the model (e.g. "n4sid"), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// Method-specific diagnostics (singular values, chosen order, …);
    /// `null` when absent.
    #[serde(default)]
    pub diagnostics: serde_json::Value,
    /// The offsets (u₀, y₀) the model is linearised about, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operating_point: Option<OperatingPoint>,
    /// Rows of the Kalman predictor gain K (n × n_y) of the innovations form
    /// x(k+1) = A x + B u + K e, if estimated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kalman_gain: Option<Vec<Vec<f64>>>,
    /// The polynomial model of a `"polynomial"` file (`model` and
    /// `kalman_gain` are then its innovations realisation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polynomial: Option<PolyModel>,
    /// The covariance of a state-space model's entries (A, B, C, D), when
    /// estimated ([`SsCovariance`]: bands on its responses).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub covariance: Option<SsCovariance>,
}

impl ModelFile {
    /// A model file without method or diagnostics.
    pub fn new(model: StateSpace) -> Self {
        ModelFile {
            kind: STATE_SPACE_KIND.to_string(),
            model,
            method: None,
            diagnostics: serde_json::Value::Null,
            operating_point: None,
            kalman_gain: None,
            polynomial: None,
            covariance: None,
        }
    }

    /// The file with the covariance of the model's entries.
    ///
    /// Errors: [`crate::Error::DimensionMismatch`] when the covariance is
    /// not of the model's dimensions.
    pub fn with_covariance(mut self, covariance: SsCovariance) -> crate::Result<Self> {
        covariance.parameters(&self.model)?;
        self.covariance = Some(covariance);
        Ok(self)
    }

    /// A `"polynomial"` model file: the innovations realisation of `poly`
    /// ([`PolyModel::to_innovations_ss`]) as the model and its Kalman gain,
    /// and `poly` itself (channel names from `poly`). O(n²).
    ///
    /// Errors: none for a valid model (the `Result` is for uniformity).
    pub fn with_polynomial(poly: PolyModel) -> crate::Result<Self> {
        let (model, k) = poly.to_innovations_ss()?;
        let mut f = ModelFile::new(model).with_kalman_gain(&k)?;
        f.kind = POLYNOMIAL_KIND.to_string();
        f.polynomial = Some(poly);
        Ok(f)
    }

    /// Records the operating point (checked against the model's channels).
    ///
    /// Errors: [`crate::Error::DimensionMismatch`].
    pub fn with_operating_point(mut self, op: OperatingPoint) -> crate::Result<Self> {
        op.check_dims(self.model.n_inputs(), self.model.n_outputs())?;
        self.operating_point = Some(op);
        Ok(self)
    }

    /// Records the Kalman predictor gain K (n × n_y).
    ///
    /// Errors: [`crate::Error::DimensionMismatch`] for a wrong shape,
    /// [`crate::Error::NonFiniteScalar`] for a NaN/inf entry.
    pub fn with_kalman_gain(mut self, k: &DMatrix<f64>) -> crate::Result<Self> {
        check_gain(&self.model, k)?;
        self.kalman_gain = Some(k.row_iter().map(|r| r.iter().copied().collect()).collect());
        Ok(self)
    }

    /// The Kalman predictor gain K as a matrix, if present.
    pub fn kalman_gain_matrix(&self) -> Option<DMatrix<f64>> {
        let rows = self.kalman_gain.as_ref()?;
        let ny = rows.first().map_or(self.model.n_outputs(), Vec::len);
        Some(DMatrix::from_fn(rows.len(), ny, |i, j| rows[i][j]))
    }

    /// Records the method.
    pub fn with_method(mut self, method: impl Into<String>) -> Self {
        self.method = Some(method.into());
        self
    }

    /// Records the diagnostics.
    pub fn with_diagnostics(mut self, diagnostics: serde_json::Value) -> Self {
        self.diagnostics = diagnostics;
        self
    }

    /// Pretty-printed JSON; arrays of numbers (matrix rows, singular
    /// values) stay on one line.
    pub fn to_json(&self) -> Result<String, ModelFileError> {
        let v = serde_json::to_value(self).map_err(|e| ModelFileError::Invalid {
            path: "<string>".into(),
            reason: e.to_string(),
        })?;
        let mut out = String::new();
        pretty(&v, 0, &mut out);
        Ok(out)
    }

    /// Parses and validates a model file held in memory.
    pub fn from_json(s: &str) -> Result<Self, ModelFileError> {
        Self::parse(s, "<string>")
    }

    fn parse(s: &str, path: &str) -> Result<Self, ModelFileError> {
        let f: ModelFile = serde_json::from_str(s).map_err(|e| ModelFileError::Invalid {
            path: path.to_string(),
            reason: crate::ss::json_reason(&e),
        })?;
        if f.kind != STATE_SPACE_KIND && f.kind != POLYNOMIAL_KIND {
            return Err(ModelFileError::UnsupportedKind {
                path: path.to_string(),
                kind: f.kind,
            });
        }
        let invalid = |reason: String| ModelFileError::Invalid {
            path: path.to_string(),
            reason,
        };
        match (&f.polynomial, f.kind == POLYNOMIAL_KIND) {
            (None, true) => {
                return Err(invalid(
                    "kind \"polynomial\" without a `polynomial` field".into(),
                ));
            }
            (Some(_), false) => {
                return Err(invalid(format!(
                    "a `polynomial` field in a file of kind \"{}\" (expected \"polynomial\")",
                    f.kind
                )));
            }
            (Some(p), true) => {
                if !crate::error::same_domain(Some(p.ts()), f.model.ts()) {
                    return Err(invalid(format!(
                        "polynomial: ts {} differs from the matrices' {:?}",
                        p.ts(),
                        f.model.ts()
                    )));
                }
                if (p.n_inputs(), p.n_outputs()) != (f.model.n_inputs(), f.model.n_outputs()) {
                    return Err(invalid(format!(
                        "polynomial: {} inputs and {} outputs, the matrices {} and {}",
                        p.n_inputs(),
                        p.n_outputs(),
                        f.model.n_inputs(),
                        f.model.n_outputs()
                    )));
                }
            }
            (None, false) => {}
        }
        if let Some(op) = &f.operating_point {
            op.check_dims(f.model.n_inputs(), f.model.n_outputs())
                .and_then(|_| OperatingPoint::new(op.u0.clone(), op.y0.clone()).map(|_| ()))
                .map_err(|e| invalid(format!("operating_point: {e}")))?;
        }
        if let Some(rows) = &f.kalman_gain {
            let ny = f.model.n_outputs();
            if rows.len() != f.model.order() || rows.iter().any(|r| r.len() != ny) {
                return Err(invalid(format!(
                    "kalman_gain: expected {} rows of {ny} values",
                    f.model.order()
                )));
            }
            if rows.iter().flatten().any(|v| !v.is_finite()) {
                return Err(invalid("kalman_gain: non-finite entry".into()));
            }
        }
        Ok(f)
    }

    /// Reads and validates a model file.
    pub fn read(path: impl AsRef<Path>) -> Result<Self, ModelFileError> {
        let p = path.as_ref();
        let text = std::fs::read_to_string(p).map_err(|e| ModelFileError::Io {
            path: p.display().to_string(),
            reason: e.to_string(),
        })?;
        Self::parse(&text, &p.display().to_string())
    }

    /// Writes the model file (pretty-printed JSON).
    pub fn write(&self, path: impl AsRef<Path>) -> Result<(), ModelFileError> {
        let p = path.as_ref();
        let json = self.to_json()?;
        std::fs::write(p, json + "\n").map_err(|e| ModelFileError::Io {
            path: p.display().to_string(),
            reason: e.to_string(),
        })
    }
}

/// Indented JSON with scalar-only arrays on one line. O(size).
fn pretty(v: &serde_json::Value, indent: usize, out: &mut String) {
    use serde_json::Value;
    let pad = |n: usize| "  ".repeat(n);
    match v {
        Value::Array(items) if items.is_empty() => out.push_str("[]"),
        Value::Array(items) if items.iter().all(|x| !x.is_array() && !x.is_object()) => {
            out.push('[');
            for (i, x) in items.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                out.push_str(&x.to_string());
            }
            out.push(']');
        }
        Value::Array(items) => {
            out.push_str("[\n");
            for (i, x) in items.iter().enumerate() {
                out.push_str(&pad(indent + 1));
                pretty(x, indent + 1, out);
                out.push_str(if i + 1 < items.len() { ",\n" } else { "\n" });
            }
            out.push_str(&pad(indent));
            out.push(']');
        }
        Value::Object(map) if map.is_empty() => out.push_str("{}"),
        Value::Object(map) => {
            out.push_str("{\n");
            for (i, (k, x)) in map.iter().enumerate() {
                out.push_str(&pad(indent + 1));
                out.push_str(&Value::String(k.clone()).to_string());
                out.push_str(": ");
                pretty(x, indent + 1, out);
                out.push_str(if i + 1 < map.len() { ",\n" } else { "\n" });
            }
            out.push_str(&pad(indent));
            out.push('}');
        }
        scalar => out.push_str(&scalar.to_string()),
    }
}

impl From<StateSpace> for ModelFile {
    fn from(model: StateSpace) -> Self {
        ModelFile::new(model)
    }
}

impl From<ModelFile> for StateSpace {
    fn from(file: ModelFile) -> Self {
        file.model
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn continuous_model_round_trips_with_null_ts() {
        let g = StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -2.0, -3.0]),
            DMatrix::from_row_slice(2, 1, &[0.0, 1.0]),
            DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
            DMatrix::zeros(1, 1),
            None,
        )
        .and_then(|g| g.with_input_names(vec!["u".into()]))
        .unwrap();
        let f = ModelFile::new(g.clone()).with_diagnostics(serde_json::json!({"order": 2}));
        let json = f.to_json().unwrap();
        assert!(json.contains("\"ts\": null"));
        assert!(json.contains("\"kind\": \"state_space\""));
        let back = ModelFile::from_json(&json).unwrap();
        assert_eq!(back.model, g);
        assert_eq!(back.diagnostics["order"], 2);
    }

    #[test]
    fn rejects_wrong_kind_and_bad_shapes() {
        let bad_kind = r#"{"kind":"tf","ts":1.0,"a":[[0.5]],"b":[[1]],"c":[[1]],"d":[[0]]}"#;
        assert!(matches!(
            ModelFile::from_json(bad_kind),
            Err(ModelFileError::UnsupportedKind { .. })
        ));
        let bad_shape =
            r#"{"kind":"state_space","ts":1.0,"a":[[0.5, 1]],"b":[[1]],"c":[[1]],"d":[[0]]}"#;
        assert!(matches!(
            ModelFile::from_json(bad_shape),
            Err(ModelFileError::Invalid { .. })
        ));
        let bad_ts =
            r#"{"kind":"state_space","ts":-1.0,"a":[[0.5]],"b":[[1]],"c":[[1]],"d":[[0]]}"#;
        assert!(ModelFile::from_json(bad_ts).is_err());
        // A dropped or misspelt `ts` is named (it loaded as continuous
        // time); null is the continuous-time model.
        let no_ts = r#"{"kind":"state_space","tS":0.1,"a":[[0.5]],"b":[[1]],"c":[[1]],"d":[[0]]}"#;
        let e = ModelFile::from_json(no_ts).expect_err("no ts").to_string();
        assert!(
            e.contains("missing field `ts`") && e.contains("null for a continuous-time"),
            "{e}"
        );
        let e = StateSpace::from_json(no_ts).expect_err("no ts").to_string();
        assert!(e.contains("missing field `ts`"), "{e}");
        let continuous =
            r#"{"kind":"state_space","ts":null,"a":[[-0.5]],"b":[[1]],"c":[[1]],"d":[[0]]}"#;
        assert_eq!(
            ModelFile::from_json(continuous)
                .expect("continuous")
                .model
                .ts(),
            None
        );
    }

    #[test]
    fn polynomial_model_round_trips() {
        let p = PolyModel::armax(&[1.0, -1.5, 0.7], &[1.0, 0.5], &[1.0, -0.2], 1, 0.5)
            .and_then(|p| p.with_covariance(&DMatrix::from_diagonal_element(5, 5, 1e-4)))
            .and_then(|p| p.with_noise_variance(&DMatrix::from_element(1, 1, 0.04)))
            .and_then(|p| p.with_input_names(vec!["u".into()]))
            .unwrap();
        let f = ModelFile::with_polynomial(p.clone())
            .unwrap()
            .with_method("armax");
        let json = f.to_json().unwrap();
        assert!(json.contains("\"kind\": \"polynomial\""));
        let back = ModelFile::from_json(&json).unwrap();
        assert_eq!(back, f);
        assert_eq!(back.polynomial.as_ref(), Some(&p));
        assert_eq!(
            back.polynomial.as_ref().and_then(PolyModel::std).unwrap()[0],
            1e-2
        );
        // The state-space part is the innovations realisation.
        let (ss, k) = p.to_innovations_ss().unwrap();
        assert_eq!(back.model, ss);
        assert_eq!(back.kalman_gain_matrix(), Some(k));
        assert_eq!(back.model.input_names(), Some(&["u".to_string()][..]));
    }

    #[test]
    fn polynomial_kind_and_field_must_agree() {
        let p = PolyModel::oe(&[1.0], &[1.0, -0.5], 1, 1.0).unwrap();
        let f = ModelFile::with_polynomial(p).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(&f.to_json().unwrap()).unwrap();
        let mut no_field = v.clone();
        no_field.as_object_mut().unwrap().remove("polynomial");
        assert!(matches!(
            ModelFile::from_json(&no_field.to_string()),
            Err(ModelFileError::Invalid { .. })
        ));
        let mut wrong_kind = v.clone();
        wrong_kind["kind"] = "state_space".into();
        assert!(matches!(
            ModelFile::from_json(&wrong_kind.to_string()),
            Err(ModelFileError::Invalid { .. })
        ));
        v["polynomial"]["ts"] = 2.0.into();
        let e = ModelFile::from_json(&v.to_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("ts"), "{e}");
    }

    #[test]
    fn missing_file_names_the_path() {
        let e = ModelFile::read("/nonexistent/model.json").unwrap_err();
        assert!(e.to_string().contains("/nonexistent/model.json"));
    }
}
