//! `lifted studio`: the interactive identification page of Zhu (2000)
//! §III.D (Fig. 2) on a local web server (127.0.0.1 only).
//!
//! The page has Zhu's blocks: load/save (a CSV by file picker or
//! drag-and-drop; save the model file and the HTML report), system input
//! and output (the channels with their holds and sampling periods, slow
//! outputs drawn as markers), the method and its parameters (q, horizon,
//! n_r, PRBS order, output weighting Q, …), order selection (the Λ diagonal
//! of eq. III-25 or the singular values on a log scale, with a slider for
//! the order r) and the system response (model response over the measured
//! response, the response error, fit % per output, step response, Bode
//! plot, pole-zero map). Moving the order or q slider re-identifies.
//!
//! Plots are SVG drawn on the server by the same code as `lifted report`
//! ([`crate::service::figures`]); the page, its script and style are
//! embedded in the binary, so it works offline.
//!
//! # JSON API
//!
//! | call | body | answer |
//! |---|---|---|
//! | `POST /api/data?name=F` | the CSV file's bytes | [`DataInfo`]: rows, base period, columns (samples, period), suggested inputs/outputs |
//! | `GET /api/data` | – | the loaded record's [`DataInfo`] or `null` |
//! | `POST /api/view` | [`Request`] (channels) | [`View`]: channels with rates, SVG of inputs and outputs |
//! | `POST /api/identify` | [`Request`] | [`Identified`]: equivalent command line, order, order-selection values, fit % per output, poles, SVG figures |
//! | `GET /api/model` | – | the last model as the model-file JSON of `lifted identify` |
//! | `GET /api/report` | – | the HTML report of `lifted report` for the last model |
//! | `GET /api/health` | – | `ok` |
//!
//! A [`Request`]'s fields are the options of `lifted identify`, with the
//! same names and defaults (`inputs`, `outputs`, `ts`, `hold`,
//! `output_period`, `method`, `order`, `max_order`, `horizon`, `q`,
//! `prbs_order`, `amplitude`, `output_weight`, `instrument`, `detrend`,
//! `estimator`, `order_criterion`, `stable`); they are handed to the
//! command's own option parser, so the saved model equals the one
//! `lifted identify` writes with the same options. An error answers
//! `400 {"error": "…"}` with the command's one-line message (a bad CSV
//! names the uploaded file, the line and the column).

mod api;
mod session;

use std::io::Write;
use std::sync::{Arc, Mutex};

pub use api::{Access, MAX_JSON, SECURITY_HEADERS, TOKEN_HEADER, lock, router};
pub use session::{
    Channel, ColumnInfo, DataInfo, Figures, Fit, Identified, MAX_UPLOAD, MAX_WORK_BYTES,
    OrderSelection, Request, Session, View,
};

use crate::error::{CliResult, input};

/// Serves the studio on 127.0.0.1:`port` (0: any free port) until Ctrl-C or
/// SIGTERM; prints `lifted studio: http://127.0.0.1:PORT/?token=TOKEN`
/// first (the page's URL with the session token). With `data`, that CSV is
/// loaded at start (a bad file is an error before the server starts). The
/// scratch directory is removed on every way out: a stop signal, an error,
/// a panic (the session's drop).
pub fn run(data: Option<&str>, port: u16) -> CliResult<()> {
    let mut session = Session::new(&std::env::temp_dir())?;
    if let Some(path) = data {
        session.open(path)?;
    }
    let dir = session.dir().to_path_buf();
    let state = Arc::new(Mutex::new(session));
    let served = serve(state.clone(), port);
    // The server's tasks are gone; remove the directory even if a blocking
    // call still holds the session.
    let _ = std::fs::remove_dir_all(&dir);
    drop(state);
    served
}

fn serve(state: Arc<Mutex<Session>>, port: u16) -> CliResult<()> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| input(format!("studio: cannot start the runtime: {e}")))?;
    let served = rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(("127.0.0.1", port))
            .await
            .map_err(|e| input(format!("studio: cannot listen on 127.0.0.1:{port}: {e}")))?;
        let addr = listener
            .local_addr()
            .map_err(|e| input(format!("studio: {e}")))?;
        let access = Access::new(addr.port())?;
        println!("lifted studio: {} (Ctrl-C to stop)", access.url());
        let _ = std::io::stdout().flush();
        axum::serve(listener, router(state, access))
            .with_graceful_shutdown(stop_signal())
            .await
            .map_err(|e| input(format!("studio: {e}")))
    });
    // Do not wait for a long identification still running on the blocking
    // pool: the process is about to end.
    rt.shutdown_timeout(std::time::Duration::from_secs(1));
    served
}

/// Ctrl-C, or SIGTERM on Unix.
async fn stop_signal() {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        match signal(SignalKind::terminate()) {
            Ok(mut term) => {
                tokio::select! {
                    _ = tokio::signal::ctrl_c() => {}
                    _ = term.recv() => {}
                }
            }
            Err(_) => {
                let _ = tokio::signal::ctrl_c().await;
            }
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
    }
}
