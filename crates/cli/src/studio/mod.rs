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
//! # Security
//!
//! A server on 127.0.0.1 is reachable by every page the user's browser
//! opens, so the studio follows Jupyter's server:
//!
//! * **Token.** At start the studio draws a session token (32 bytes of the
//!   operating system's CSPRNG, 64 hex digits) and prints the page's URL
//!   with it: `lifted studio: http://127.0.0.1:PORT/?token=TOKEN`. The page
//!   is served only with the token and carries it in a `<meta
//!   name="lifted-token">` tag; its script sends it as the
//!   `X-Lifted-Token` header on every call. A `GET` may give it as
//!   `?token=` instead (the printed URL, the Save links); a `POST` only as
//!   the header, which a page of another origin cannot send without a CORS
//!   preflight, which the studio refuses. Without the token: `403`.
//!   `/app.js`, `/app.css`, `/api/health` and `/favicon.ico` need none.
//! * **Host.** Only `127.0.0.1:PORT`, `localhost:PORT` and `[::1]:PORT` (the
//!   bound port): a DNS-rebound name is refused (`403`).
//! * **Same origin.** An `Origin` header must be the server's own origin
//!   (`http://` + the request's `Host`); a `Sec-Fetch-Site` of `cross-site`
//!   or `same-site` (another port of 127.0.0.1 is same-site) is refused
//!   (`403`), `same-origin` and `none` pass.
//! * **Content types.** `POST /api/view` and `/api/identify` take
//!   `application/json` only, `POST /api/data` `application/octet-stream`
//!   or `text/csv` (else `415`), so no HTML form or `no-cors` fetch can make
//!   a call.
//! * **Body limits.** JSON calls take at most [`MAX_JSON`] (1 MiB); an
//!   upload at most [`MAX_UPLOAD`] (1 GiB), streamed to a file of the
//!   scratch directory, never held in memory (else `413`).
//! * **Headers** on every answer, refusals included ([`SECURITY_HEADERS`]):
//!   `Content-Security-Policy: default-src 'none'; script-src 'self';
//!   style-src 'self'; img-src 'self' data:; connect-src 'self'; base-uri
//!   'none'; form-action 'none'; frame-ancestors 'none'` (the page has no
//!   inline script or style; the SVG figures, the only markup it inserts,
//!   are drawn by the server), `X-Content-Type-Options: nosniff`,
//!   `X-Frame-Options: DENY`, `Referrer-Policy: no-referrer`,
//!   `Cache-Control: no-store`, `Cross-Origin-Opener-Policy` and
//!   `Cross-Origin-Resource-Policy: same-origin`.
//! * **Scratch directory** `lifted-studio-<32 random hex digits>` under the
//!   system's temp directory, mode 0700, removed on every way out (Ctrl-C,
//!   SIGTERM, an error, a panic).
//! * **State changes only after the input has been read whole.** An upload
//!   goes to a folder of its own and replaces the loaded record only once
//!   it has been read without error; a bad file leaves the record and the
//!   model as they were. An identification whose horizon, q, order or hold
//!   the record cannot support is refused before anything is allocated
//!   ([`Session::check_sizes`]). A call that panics poisons the session's
//!   lock; the next call resets the session (no record, no model) rather
//!   than reuse what the failed call left.
//!
//! Every refusal is logged on stderr (`lifted studio: refused POST
//! /api/data: …`).
//!
//! # JSON API
//!
//! Every call but `/api/health` carries the token (`X-Lifted-Token: TOKEN`,
//! or `?token=TOKEN` on a `GET`).
//!
//! **Sessions.** Each browser tab has its own session: the page draws a
//! random id on load, opens it with `POST /api/session` and sends it as
//! `X-Lifted-Session` with every call (a `GET` may give `?session=`). A new
//! session starts with a copy of the default session's record (the one
//! `--data` loaded, or a call without an id uploaded) and then keeps its
//! own record and models, in a folder `session-…` of the scratch
//! directory; at most [`MAX_SESSIONS`] (8) are kept, the least recently
//! used dropped with its folder. A call naming a session that is not open
//! (dropped for newer tabs, or from before a restart) is answered 410 Gone
//! with [`SESSION_EXPIRED`] ("reload the page"), which the page shows:
//! never another record's model under the old file name. Calls without an
//! id use the default session.
//!
//! **One model shown, one saved.** The page numbers its identify requests
//! (`seq`), drops an answer older than its latest request, never moves the
//! order slider from an answer (unless the order is `auto`), and its Save
//! links ask for the model of the sequence number it shows
//! (`/api/model?seq=N`); a session keeps its last [`KEPT_MODELS`] (8).
//!
//! | call | content type | body | answer |
//! |---|---|---|---|
//! | `GET /?token=T` | – | – | the page (with the token in its meta tag) |
//! | `POST /api/session` | `application/json` | – | opens the session of `X-Lifted-Session` (kept if open); its record's [`DataInfo`] or `null` |
//! | `POST /api/data?name=F` | `application/octet-stream` or `text/csv` | the CSV file's bytes (≤ 1 GiB) | [`DataInfo`]: rows, base period, columns (samples, period), suggested inputs/outputs |
//! | `GET /api/data` | – | – | the loaded record's [`DataInfo`] or `null` |
//! | `POST /api/view` | `application/json` | [`Request`] (channels; ≤ 1 MiB) | [`View`]: channels with rates, SVG of inputs and outputs |
//! | `POST /api/identify` | `application/json` | [`Request`] (≤ 1 MiB, with the page's sequence number `seq`) | [`Identified`]: `seq` echoed, equivalent command line, order, stability (`stable`, `spectral_radius`), order-selection values, fit % per output (`null` with `stable: false` for an unstable model), poles, SVG figures |
//! | `GET /api/model[?seq=N]` | – | – | the model of request N (the last model without `seq`) as the model-file JSON of `lifted identify` |
//! | `GET /api/report[?seq=N]` | – | – | the HTML report of `lifted report` for that model |
//! | `GET /api/plan[?seq=N]` | – | – | that model's workflow options (`lifted identify --write-plan`'s plan file) |
//! | `POST /api/data?name=F&role=validation` | as above | the validation record's bytes | its [`DataInfo`]; the fits, residuals and the board are then computed on it |
//! | `POST /api/data?name=F&role=experiment` | as above | a further estimation record (q-Markov: one file per input, in input order) | its [`DataInfo`]; each is a `--data` of the command after the record |
//! | `POST /api/experiments/clear` | `application/json` | – | `null`; the record alone again |
//! | `POST /api/validation/clear` | `application/json` | – | `null`; models are validated on the estimation record again |
//! | `POST /api/board` | `application/json` | [`BoardRequest`] (keep the model of request `add`, remove `remove`, overlay `selected`) | [`BoardView`]: fit table over the kept models, overlaid outputs, steps, Bode |
//! | `POST /api/delay` | `application/json` | [`Request`] (channels) | [`Delays`]: `lifted delay`'s interval per input-output pair |
//! | `GET /api/model?board=ID` | – | – | a kept model's model file |
//! | `GET /api/estimation-data[?seq=N]` | – | – | the CSV file the command line of model N names (the record, or the rows of its estimation range) |
//! | `GET /api/health` | – | – | `ok` (no token needed) |
//!
//! A [`Request`]'s fields are the options of `lifted identify`, with the
//! same names and defaults (`inputs`, `outputs`, `ts`, `hold`,
//! `output_period`, `method`, `order`, `max_order`, `horizon`, `q`,
//! `prbs_order`, `amplitude`, `output_weight`, `instrument`, `detrend`,
//! `estimator`, `order_criterion`, `stable`, `refine`); they are set field
//! by field on the command's arguments (no command line parsed again) and
//! converted by the command's own conversion, so the saved model equals the
//! one `lifted identify` writes with the same options (a test checks the
//! arguments against those the shown command line parses to). Besides them: `seq`,
//! `window` (the time plots' zoom, seconds), `estimation_range` and
//! `validation_range` (rows of the record, seconds: [`ranges`]). The
//! parsed record and the subspace compression are kept between requests
//! (`cached`), so a move of the order slider costs neither a read nor a
//! compression. A failed identification
//! leaves no model (`GET /api/model` then answers `400`).
//!
//! # Errors
//!
//! Every error is JSON, `{"error": "…"}`, with its status:
//!
//! | status | when |
//! |---|---|
//! | `400` | the command's one-line message (a bad CSV names the uploaded file, the line and the column; `horizon 100000 is too large for rec.csv: the block Hankel matrix would have …`) |
//! | `403` | a foreign `Host`, a foreign `Origin`, `Sec-Fetch-Site: cross-site`/`same-site`, a missing or wrong token |
//! | `404`, `405` | no such page or call, or not with that method |
//! | `413` | a body over the route's limit (`request body too large: /api/identify takes at most 1 MiB`) |
//! | `415` | a `POST` with another content type |
//! | `500` | a bug inside the studio (the server keeps running; the session is reset) |

mod api;
mod board;
mod cached;
pub mod ranges;
mod session;

use std::io::Write;
use std::sync::Arc;

pub use api::{
    Access, MAX_JSON, MAX_SESSIONS, SECURITY_HEADERS, SESSION_EXPIRED, SESSION_HEADER, Sessions,
    TOKEN_HEADER, lock, router,
};
pub use board::{BoardEntry, BoardRequest, BoardView, MAX_BOARD};
pub use session::{
    Channel, ChannelTf, ColumnInfo, DataInfo, Delays, Figures, Fit, Identified, KEPT_MODELS,
    MAX_EXPERIMENTS, MAX_UPLOAD, MAX_WORK_BYTES, Matrices, OrderSelection, PairDelay, Request,
    Session, View,
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
    let state = Arc::new(Sessions::new(session));
    let served = serve(state.clone(), port);
    // The server's tasks are gone; remove the directory even if a blocking
    // call still holds the session.
    let _ = std::fs::remove_dir_all(&dir);
    drop(state);
    served
}

fn serve(state: Arc<Sessions>, port: u16) -> CliResult<()> {
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
