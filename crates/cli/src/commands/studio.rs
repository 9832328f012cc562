//! `lifted studio`: serves the interactive identification page
//! ([`lifted_cli::studio`]).

use crate::args::StudioArgs;
use crate::error::CliResult;

/// `lifted studio`.
pub fn studio_cmd(a: &StudioArgs) -> CliResult<()> {
    lifted_cli::studio::run(a.data.as_deref(), a.port)
}
