//! `lifted delay`: the delay interval of every input-output pair (thesis
//! §4.4 per pair, `lifted_multirate::estimate_delays`).

use lifted_multirate::estimate_delays;
use serde_json::json;

use crate::args::DelayArgs;
use crate::error::{CliResult, Context, input};
use crate::table::load;
use crate::terminal::print_table;
use lifted_cli::service::identify::data_spec;

/// `lifted delay`.
pub fn delay_cmd(a: &DelayArgs) -> CliResult<()> {
    if a.hold == 0 {
        return Err(input("--hold must be at least 1"));
    }
    if a.lags == 0 {
        return Err(input("--lags must be at least 1"));
    }
    if !(a.sigmas.is_finite() && a.sigmas > 0.0) {
        return Err(input(format!(
            "--sigmas {}: must be positive and finite",
            a.sigmas
        )));
    }
    let spec = data_spec(&a.columns, None, a.hold, Vec::new())?;
    let data = load(&a.data, &spec)?.data;
    let pairs = estimate_delays(&data, a.lags, a.sigmas).ctx("delay estimation")?;
    let ts = data.ts();
    if a.json {
        let rows: Vec<serde_json::Value> = pairs
            .iter()
            .map(|p| {
                json!({
                    "input": spec.inputs[p.input],
                    "output": spec.outputs[p.output],
                    "hold": p.hold,
                    "period": p.period,
                    "interval": p.interval.map(|iv| [iv.lower, iv.upper]),
                    "interval_s": p.interval.map(|iv| [iv.lower as f64 * ts, iv.upper as f64 * ts]),
                    "failure": p.failure,
                })
            })
            .collect();
        println!(
            "{}",
            serde_json::to_string_pretty(&json!({"base_period": ts, "pairs": rows})).ctx("JSON")?
        );
        return Ok(());
    }
    let rows: Vec<Vec<String>> = pairs
        .iter()
        .map(|p| {
            let (iv, secs) = match p.interval {
                Some(iv) => (
                    format!("[{}, {})", iv.lower, iv.upper),
                    format!("[{}, {})", iv.lower as f64 * ts, iv.upper as f64 * ts),
                ),
                None => ("–".to_string(), p.failure.clone().unwrap_or_default()),
            };
            vec![
                spec.inputs[p.input].clone(),
                spec.outputs[p.output].clone(),
                p.hold.to_string(),
                p.period.to_string(),
                iv,
                secs,
            ]
        })
        .collect();
    print_table(
        &[
            "input",
            "output",
            "hold m",
            "period n",
            "delay (T)",
            "delay (s) / why none",
        ],
        &rows,
    );
    println!(
        "(d_c ∈ [lower, upper) base periods per pair; lifted FIR estimate, {} lags, {}σ)",
        a.lags, a.sigmas
    );
    Ok(())
}
