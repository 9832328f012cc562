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
//! `input_names`, `output_names`, `method` and `diagnostics` are optional
//! when reading. The matrices are validated exactly as
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

use crate::ss::StateSpace;

/// The only `kind` written and accepted.
pub const STATE_SPACE_KIND: &str = "state_space";

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
    /// `kind` is not `"state_space"`.
    #[error("{path}: unsupported model kind '{kind}' (expected \"state_space\")")]
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
    /// Always [`STATE_SPACE_KIND`].
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
}

impl ModelFile {
    /// A model file without method or diagnostics.
    pub fn new(model: StateSpace) -> Self {
        ModelFile {
            kind: STATE_SPACE_KIND.to_string(),
            model,
            method: None,
            diagnostics: serde_json::Value::Null,
        }
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
            reason: e.to_string(),
        })?;
        if f.kind != STATE_SPACE_KIND {
            return Err(ModelFileError::UnsupportedKind {
                path: path.to_string(),
                kind: f.kind,
            });
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
    }

    #[test]
    fn missing_file_names_the_path() {
        let e = ModelFile::read("/nonexistent/model.json").unwrap_err();
        assert!(e.to_string().contains("/nonexistent/model.json"));
    }
}
