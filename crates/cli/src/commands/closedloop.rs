//! `lifted closedloop`: the plant from identified closed-loop models by the
//! recovery formulas of Ren & Zhu (2009) eqs. (10)–(12)
//! (`lifted_closedloop::recover`).

use lifted_closedloop::recover::{self, RecoveryOptions, Setup};
use lifted_lti::{ModelFile, StateSpace};
use serde_json::json;

use crate::args::{ClosedloopArgs, SetupArg};
use crate::error::{CliResult, Context, input};
use lifted_cli::service::models::{read_model, write_model};

fn setup_of(s: SetupArg) -> Setup {
    match s {
        SetupArg::General => Setup::General,
        SetupArg::Controller => Setup::Controller,
        SetupArg::Compensator => Setup::Compensator,
    }
}

/// The model in `path`, required for this set-up.
fn need(path: &Option<String>, flag: &str, setup: Setup) -> CliResult<StateSpace> {
    match path {
        Some(p) => Ok(read_model(p)?.model),
        None => Err(input(format!(
            "--setup {setup} (eq. {}) needs {flag}",
            setup.equation()
        ))),
    }
}

/// `lifted closedloop`.
pub fn closedloop_cmd(a: &ClosedloopArgs) -> CliResult<()> {
    let setup = setup_of(a.setup);
    let opts = RecoveryOptions {
        minreal: if a.no_minreal {
            None
        } else {
            RecoveryOptions::default().minreal
        },
    };
    let unused = |flag: &str, given: bool| -> CliResult<()> {
        if given {
            Err(input(format!("--setup {setup} does not use {flag}")))
        } else {
            Ok(())
        }
    };
    let g = match setup {
        Setup::General => {
            unused("--controller", a.controller.is_some())?;
            let h1 = need(&a.h1, "--h1", setup)?;
            let h2 = need(&a.h2, "--h2", setup)?;
            recover::general(&h1, &h2, &opts)
        }
        Setup::Controller => {
            unused("--h2", a.h2.is_some())?;
            let h1 = need(&a.h1, "--h1", setup)?;
            let k = need(&a.controller, "--controller", setup)?;
            recover::controller(&h1, &k, &opts)
        }
        Setup::Compensator => {
            unused("--h1", a.h1.is_some())?;
            let h2 = need(&a.h2, "--h2", setup)?;
            let k = need(&a.controller, "--controller", setup)?;
            recover::compensator(&h2, &k, &opts)
        }
    }
    .ctx(format!("recovery (eq. {})", setup.equation()))?;
    let poles = g.poles().ctx("poles of the recovered plant")?;
    let dc = g.dc_gain().ok();
    let file = ModelFile::new(g.clone())
        .with_method(format!("closedloop-{setup}"))
        .with_diagnostics(json!({
            "setup": setup.to_string(),
            "equation": setup.equation(),
            "minreal": !a.no_minreal,
            "poles": poles.iter().map(|p| [p.re, p.im]).collect::<Vec<_>>(),
        }));
    write_model(&file, &a.out)?;
    println!(
        "recovered plant (eq. {}, {setup} set-up): order {}, {} input(s), {} output(s), T = {}",
        setup.equation(),
        g.order(),
        g.n_inputs(),
        g.n_outputs(),
        g.ts()
            .map_or("continuous".to_string(), |t| format!("{t} s"))
    );
    for p in &poles {
        println!("  pole {:.6} {:+.6}i", p.re, p.im);
    }
    if let Some(dc) = dc {
        println!("  DC gain {dc}");
    }
    println!("wrote {}", a.out);
    Ok(())
}
