//! The HTTP routes of the studio (axum): the page and its assets, and the
//! JSON API over [`Session`]. Each API call runs on tokio's blocking pool,
//! one at a time (the session is behind a mutex); a failed call answers
//! `400 {"error": "<the CLI's one-line message>"}`, a bug `500` with a
//! message, and the server keeps running either way.

use std::sync::{Arc, Mutex};

use axum::Router;
use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, Query, State};
use axum::http::{StatusCode, header};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::error::{CliResult, input};
use crate::studio::session::{MAX_UPLOAD, Request, Session};

/// The session shared by the handlers.
pub type Shared = Arc<Mutex<Session>>;

const INDEX: &str = include_str!("assets/index.html");
const APP_JS: &str = include_str!("assets/app.js");
const APP_CSS: &str = include_str!("assets/app.css");

/// The studio's routes (see the module documentation of [`crate::studio`]).
pub fn router(state: Shared) -> Router {
    Router::new()
        .route("/", get(|| async { Html(INDEX) }))
        .route(
            "/app.js",
            get(|| async { asset(APP_JS, "text/javascript") }),
        )
        .route("/app.css", get(|| async { asset(APP_CSS, "text/css") }))
        .route("/api/health", get(|| async { "ok" }))
        .route("/api/data", post(upload).get(data_info))
        .route("/api/view", post(view))
        .route("/api/identify", post(identify))
        .route("/api/model", get(model))
        .route("/api/report", get(report))
        .layer(DefaultBodyLimit::max(MAX_UPLOAD))
        .with_state(state)
}

fn asset(body: &'static str, mime: &'static str) -> Response {
    ([(header::CONTENT_TYPE, mime)], body).into_response()
}

fn error(status: StatusCode, msg: impl std::fmt::Display) -> Response {
    (status, axum::Json(json!({ "error": msg.to_string() }))).into_response()
}

/// Runs `f` on the session in the blocking pool.
async fn with_session<T: Send + 'static>(
    state: Shared,
    f: impl FnOnce(&mut Session) -> CliResult<T> + Send + 'static,
) -> Result<T, Response> {
    let joined = tokio::task::spawn_blocking(move || {
        let mut s = state.lock().unwrap_or_else(|p| p.into_inner());
        f(&mut s)
    })
    .await;
    match joined {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(error(StatusCode::BAD_REQUEST, e)),
        Err(_) => Err(error(
            StatusCode::INTERNAL_SERVER_ERROR,
            "internal error while handling the request (the studio keeps running)",
        )),
    }
}

fn json_answer<T: Serialize>(r: Result<T, Response>) -> Response {
    match r {
        Ok(v) => axum::Json(v).into_response(),
        Err(e) => e,
    }
}

fn parse_request(body: &[u8]) -> CliResult<Request> {
    if body.iter().all(u8::is_ascii_whitespace) {
        return Ok(Request::default());
    }
    serde_json::from_slice(body).map_err(|e| input(format!("request: {e}")))
}

/// `?name=` of an upload.
#[derive(Debug, Deserialize)]
struct UploadQuery {
    name: Option<String>,
}

async fn upload(State(s): State<Shared>, Query(q): Query<UploadQuery>, body: Bytes) -> Response {
    let name = q.name.unwrap_or_else(|| "data.csv".into());
    json_answer(with_session(s, move |s| s.upload(&name, &body)).await)
}

async fn data_info(State(s): State<Shared>) -> Response {
    json_answer(with_session(s, |s| Ok(s.data_info().cloned())).await)
}

async fn view(State(s): State<Shared>, body: Bytes) -> Response {
    json_answer(with_session(s, move |s| s.view(&parse_request(&body)?)).await)
}

async fn identify(State(s): State<Shared>, body: Bytes) -> Response {
    json_answer(with_session(s, move |s| s.identify(&parse_request(&body)?)).await)
}

fn download(body: String, mime: &'static str, file: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, mime.to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"{file}\""),
            ),
        ],
        body,
    )
        .into_response()
}

async fn model(State(s): State<Shared>) -> Response {
    match with_session(s, |s| s.model_json()).await {
        Ok(j) => download(j, "application/json", "model.json"),
        Err(e) => e,
    }
}

async fn report(State(s): State<Shared>) -> Response {
    match with_session(s, |s| s.report()).await {
        Ok(h) => download(h, "text/html; charset=utf-8", "report.html"),
        Err(e) => e,
    }
}
