//! `lifted report`: the report service's page written to a file.

use crate::args::ReportArgs;
use crate::error::{CliResult, Context};
use lifted_cli::service::report::render;
use lifted_cli::service::validation::{load_for_validation, validate_model};

/// `lifted report`.
pub fn report_cmd(a: &ReportArgs) -> CliResult<()> {
    let (file, data) = load_for_validation(&a.model, &a.data, &a.columns, a.detrend)?;
    let v = validate_model(&file, &data, a.lags, a.initial_state.condition(), &a.data)?;
    let html = render(&file, &data, &v, &a.model, &a.data)?;
    std::fs::write(&a.out, html).ctx(format!("cannot write {}", a.out))?;
    println!("wrote {}", a.out);
    Ok(())
}
