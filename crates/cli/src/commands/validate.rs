//! `lifted validate`: the validation service's table on the terminal, and
//! the `--min-fit` check.

use crate::args::ValidateArgs;
use crate::error::{CliResult, failed};
use lifted_cli::service::validation::{
    TABLE_HEADER, fit_cell, load_for_validation, table_rows, unstable_note, validate_model,
};
use lifted_cli::shown::{percent, shown};
use lifted_cli::terminal::print_table;

/// `lifted validate`.
pub fn validate_cmd(a: &ValidateArgs) -> CliResult<()> {
    if let Some(min) = a.min_fit
        && !(min.is_finite() && min <= 100.0)
    {
        return Err(lifted_cli::error::input(format!(
            "--min-fit {min}: a fit is at most 100 %; give a finite percentage up to 100"
        )));
    }
    let (file, data) = load_for_validation(&a.model, &a.data, &a.columns, a.detrend)?;
    let v = validate_model(&file, &data, a.lags, a.initial_state.condition(), &a.data)?;
    let rows: Vec<Vec<String>> = table_rows(&v).into_iter().map(|r| r.to_vec()).collect();
    print_table(&TABLE_HEADER, &rows);
    println!(
        "({} lags of the {} residual; a test passes with at most ⌈1% of the lags⌉ outside the 99% bound ±2.576/√N)",
        v.lags,
        v.residual.name()
    );
    println!(
        "{}",
        if v.x0.is_some() {
            "(simulated from the initial state fitted to the record by least squares; --initial-state zero starts from rest)"
        } else {
            "(simulated from rest)"
        }
    );
    if let Some(note) = unstable_note(&v) {
        eprintln!("warning: {note}");
    }
    if let Some(note) = lifted_cli::service::validation::gain_mismatch(&file, &data) {
        eprintln!("note: {note}");
    }
    if let Some(min) = a.min_fit {
        let low: Vec<String> = v
            .outputs
            .iter()
            .filter(|o| !v.stable() || o.fit.is_nan() || o.fit < min)
            .map(|o| format!("{} ({} %)", shown(&o.name), fit_cell(&v, o.fit)))
            .collect();
        if !low.is_empty() {
            return Err(failed(format!(
                "fit below --min-fit {} %: {}",
                percent(min),
                low.join(", ")
            )));
        }
    }
    Ok(())
}
