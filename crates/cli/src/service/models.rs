//! Model files: reading, writing, channel names.

use lifted_lti::{ModelFile, StateSpace};

use crate::error::{CliResult, input};

/// Reads a model file; the message names the file.
pub fn read_model(path: &str) -> CliResult<ModelFile> {
    ModelFile::read(path).map_err(|e| input(e.to_string()))
}

/// Writes a model file (one-line error on failure).
pub fn write_model(file: &ModelFile, path: &str) -> CliResult<()> {
    file.write(path).map_err(|e| input(e.to_string()))
}

/// Channel names of a model (its own, else u1…, y1…).
pub fn channel_names(model: &StateSpace) -> (Vec<String>, Vec<String>) {
    let u = model
        .input_names()
        .map(<[String]>::to_vec)
        .unwrap_or_else(|| (1..=model.n_inputs()).map(|i| format!("u{i}")).collect());
    let y = model
        .output_names()
        .map(<[String]>::to_vec)
        .unwrap_or_else(|| (1..=model.n_outputs()).map(|i| format!("y{i}")).collect());
    (u, y)
}
