//! The HTTP routes of the studio (axum): the page and its assets, and the
//! JSON API over [`Session`]. Each API call runs on tokio's blocking pool,
//! one at a time (the session is behind a mutex); a failed call answers
//! `400 {"error": "<the CLI's one-line message>"}`, a bug `500` with a
//! message, and the server keeps running either way.
//!
//! Every request passes `guard` first (the model is Jupyter's server):
//! the `Host` must be this server (127.0.0.1, localhost or [::1] with its
//! port: no DNS rebinding), an `Origin` must be this server's origin, a
//! `Sec-Fetch-Site` must not be `cross-site` or `same-site`, every call but
//! the page's assets and `/api/health` carries the session token (the
//! `X-Lifted-Token` header; a `GET` may give it as `?token=` instead, as
//! the printed URL and the Save links do; a `POST` only as the header, which
//! no cross-origin page can send without a CORS preflight this server never
//! grants), and a `POST` has the route's content type. Every answer carries
//! the security headers of [`SECURITY_HEADERS`], and every error is JSON.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::pin::Pin;
use std::sync::{Arc, Mutex, MutexGuard};

use axum::Router;
use axum::body::{Body, Bytes, HttpBody};
use axum::extract::{DefaultBodyLimit, Query, Request as HttpRequest, State};
use axum::http::{HeaderMap, HeaderValue, Method, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::error::{CliResult, input};
use crate::studio::session::{MAX_UPLOAD, Request, Session, random_hex, staging};

/// A session shared by the handlers.
pub type Shared = Arc<Mutex<Session>>;

/// The header that names the browser tab's session.
pub const SESSION_HEADER: &str = "x-lifted-session";

/// Sessions of browser tabs kept at once; beyond, the least recently used
/// one is dropped (its record, models and folder go).
pub const MAX_SESSIONS: usize = 8;

/// The answer (410 Gone) to a call naming a session that is not open.
pub const SESSION_EXPIRED: &str = "this tab's session expired (the studio keeps the 8 most recently used tabs, and none across a restart): reload the page and load the record again";

/// A session and its directory (uploads are staged there outside the lock).
#[derive(Clone)]
struct Handle {
    session: Shared,
    dir: PathBuf,
}

/// The sessions of the server: the default one (calls without a session
/// id: `lifted studio --data`'s record, scripts) and one per browser tab
/// (the page draws a random id on load, opens it with `POST /api/session`
/// and sends it as `X-Lifted-Session`, or `?session=` on a GET), each in a
/// folder `session-…` of the scratch directory; at most [`MAX_SESSIONS`]
/// tabs, least recently used dropped. A new tab starts with a copy of the
/// default session's record, then keeps its own. A call naming a session
/// that is not open (dropped, or from before a restart) is answered
/// [`SESSION_EXPIRED`] with 410 Gone, never with another record's model.
pub struct Sessions {
    base: Handle,
    tabs: Mutex<Tabs>,
}

#[derive(Default)]
struct Tabs {
    clock: u64,
    /// (id, session, last use).
    open: Vec<(String, Handle, u64)>,
}

impl Tabs {
    /// Advances the clock; the tab `id`'s session, marked as just used,
    /// if it is open.
    fn touch(&mut self, id: &str) -> (u64, Option<Handle>) {
        self.clock += 1;
        let now = self.clock;
        let found = self.open.iter_mut().find(|t| t.0 == id).map(|t| {
            t.2 = now;
            t.1.clone()
        });
        (now, found)
    }
}

impl Sessions {
    /// The sessions of a server whose default session is `base`.
    pub fn new(base: Session) -> Self {
        let dir = base.dir().to_path_buf();
        Sessions {
            base: Handle {
                session: Arc::new(Mutex::new(base)),
                dir,
            },
            tabs: Mutex::new(Tabs::default()),
        }
    }

    /// The default session.
    pub fn base(&self) -> &Shared {
        &self.base.session
    }

    /// Tabs open now.
    pub fn tabs(&self) -> usize {
        self.tabs.lock().map(|t| t.open.len()).unwrap_or(0)
    }

    /// The session of `id` (the default one without): with `open`, made if
    /// it is not open yet, with a copy of the default session's record;
    /// without, `None` when it is not open (expired). An id is 8 to 64
    /// letters, digits, `-` or `_`. Blocking (it may copy a record).
    fn get(&self, id: Option<&str>, open: bool) -> CliResult<Option<Handle>> {
        let Some(id) = id else {
            return Ok(Some(self.base.clone()));
        };
        let valid = (8..=64).contains(&id.len())
            && id
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_');
        if !valid {
            return Err(input(
                "a session id is 8 to 64 letters, digits, '-' or '_' (X-Lifted-Session)",
            ));
        }
        let lock_tabs = || match self.tabs.lock() {
            Ok(t) => t,
            Err(p) => p.into_inner(),
        };
        if let (_, Some(h)) = lock_tabs().touch(id) {
            return Ok(Some(h));
        }
        if !open {
            return Ok(None);
        }
        // A new tab, made outside the map's lock (the default session may
        // be busy identifying).
        let mut s = Session::named(&self.base.dir, "session-")?;
        let seed = lock(&self.base.session).record_file();
        if let Some((name, path)) = seed {
            // If the default record is replaced meanwhile, the tab starts
            // empty.
            let _ = s.seed(&name, &path);
        }
        let handle = Handle {
            dir: s.dir().to_path_buf(),
            session: Arc::new(Mutex::new(s)),
        };
        let mut tabs = lock_tabs();
        let (now, found) = tabs.touch(id);
        if let Some(h) = found {
            // Another call of the same tab made it first: use that one.
            return Ok(Some(h));
        }
        tabs.open.push((id.to_string(), handle.clone(), now));
        if tabs.open.len() > MAX_SESSIONS
            && let Some(oldest) = tabs
                .open
                .iter()
                .enumerate()
                .min_by_key(|(_, t)| t.2)
                .map(|(i, _)| i)
        {
            // Dropped with its last handle: a call still running on it
            // finishes first.
            tabs.open.remove(oldest);
        }
        Ok(Some(handle))
    }
}

/// Largest body of a JSON call (`/api/view`, `/api/identify`), bytes.
pub const MAX_JSON: usize = 1 << 20;

/// The header that carries the session token.
pub const TOKEN_HEADER: &str = "x-lifted-token";

/// The headers of every answer: a content security policy without inline
/// script or style (the page's SVG figures are inserted as markup and
/// could carry neither), no MIME sniffing, no framing, no referrer (the
/// page's URL holds the token), no caching (the page holds the token).
pub const SECURITY_HEADERS: [(&str, &str); 7] = [
    (
        "content-security-policy",
        "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; \
         connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'",
    ),
    ("x-content-type-options", "nosniff"),
    ("x-frame-options", "DENY"),
    ("referrer-policy", "no-referrer"),
    ("cache-control", "no-store"),
    ("cross-origin-opener-policy", "same-origin"),
    ("cross-origin-resource-policy", "same-origin"),
];

const INDEX: &str = include_str!("assets/index.html");
const APP_JS: &str = include_str!("assets/app.js");
const APP_CSS: &str = include_str!("assets/app.css");

/// Who may talk to the server: its port (the allowed `Host`s and `Origin`s
/// follow) and the session token.
#[derive(Debug, Clone)]
pub struct Access {
    port: u16,
    token: String,
}

impl Access {
    /// The access rules of a server on 127.0.0.1:`port`, with a token of
    /// 32 random bytes from the operating system's CSPRNG (64 hex digits).
    pub fn new(port: u16) -> CliResult<Self> {
        Ok(Access {
            port,
            token: random_hex(32)?,
        })
    }

    /// The session token.
    pub fn token(&self) -> &str {
        &self.token
    }

    /// The URL that opens the page: `http://127.0.0.1:PORT/?token=TOKEN`.
    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}/?token={}", self.port, self.token)
    }

    /// Whether `host` (a `Host` header or URI authority) names this server.
    fn host_ok(&self, host: &str) -> bool {
        let host = host.to_ascii_lowercase();
        ["127.0.0.1", "localhost", "[::1]"]
            .iter()
            .any(|h| host == format!("{h}:{}", self.port))
    }

    /// Whether `given` is the token (in time independent of where they
    /// differ).
    fn token_ok(&self, given: &[u8]) -> bool {
        let want = self.token.as_bytes();
        given.len() == want.len() && given.iter().zip(want).fold(0u8, |d, (a, b)| d | (a ^ b)) == 0
    }

    /// The refusal of a request, if any (see the module documentation):
    /// its status and message.
    fn check(&self, req: &HttpRequest) -> Result<(), (StatusCode, String)> {
        let h = req.headers();
        let forbidden = |m: String| Err((StatusCode::FORBIDDEN, m));
        let host = text(h, header::HOST);
        let host = match host {
            Some(host) if self.host_ok(host) => host,
            Some(host) => {
                return forbidden(format!(
                    "Host '{host}' is not this studio (127.0.0.1:{} or localhost:{})",
                    self.port, self.port
                ));
            }
            None => return forbidden("a Host header is required".into()),
        };
        if let Some(a) = req.uri().authority()
            && !self.host_ok(a.as_str())
        {
            return forbidden(format!("'{a}' is not this studio"));
        }
        if let Some(origin) = h.get(header::ORIGIN) {
            let own = format!("http://{host}");
            let same = origin.to_str().is_ok_and(|o| o.eq_ignore_ascii_case(&own));
            if !same {
                return forbidden(format!(
                    "cross-origin request refused (Origin {})",
                    String::from_utf8_lossy(origin.as_bytes())
                ));
            }
        }
        if let Some(site) = text(h, "sec-fetch-site")
            && !matches!(site, "same-origin" | "none")
        {
            return forbidden(format!(
                "cross-origin request refused (Sec-Fetch-Site: {site})"
            ));
        }
        let path = req.uri().path();
        if matches!(
            path,
            "/app.js" | "/app.css" | "/api/health" | "/favicon.ico"
        ) {
            return Ok(());
        }
        let header_token = h.get(TOKEN_HEADER).map(HeaderValue::as_bytes);
        let query_token = req
            .uri()
            .query()
            .and_then(|q| q.split('&').find_map(|kv| kv.strip_prefix("token=")))
            .map(str::as_bytes);
        let read_only = matches!(*req.method(), Method::GET | Method::HEAD);
        let token = match (header_token, query_token) {
            (Some(t), _) => Some(t),
            (None, Some(t)) if read_only => Some(t),
            _ => None,
        };
        match token {
            Some(t) if self.token_ok(t) => {}
            Some(_) => return forbidden("wrong studio token".into()),
            None if read_only => {
                return forbidden(
                    "the studio token is missing: open the URL `lifted studio` printed \
                     (it ends in ?token=…)"
                        .into(),
                );
            }
            None => {
                return forbidden(
                    "the studio token is missing: state-changing calls send it as X-Lifted-Token"
                        .into(),
                );
            }
        }
        if *req.method() == Method::POST {
            let wanted: &[&str] = if path == "/api/data" {
                &["application/octet-stream", "text/csv"]
            } else {
                &["application/json"]
            };
            let given = text(h, header::CONTENT_TYPE).unwrap_or("");
            let mime = given.split(';').next().unwrap_or("").trim();
            if !wanted.iter().any(|w| mime.eq_ignore_ascii_case(w)) {
                return Err((
                    StatusCode::UNSUPPORTED_MEDIA_TYPE,
                    format!(
                        "{path} takes Content-Type {}, not '{given}'",
                        wanted.join(" or ")
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// A header's value as text, if it is text.
fn text(h: &HeaderMap, name: impl header::AsHeaderName) -> Option<&str> {
    h.get(name).and_then(|v| v.to_str().ok())
}

/// The state of the handlers.
#[derive(Clone)]
struct App {
    sessions: Arc<Sessions>,
    access: Arc<Access>,
    /// The page with the token in its `lifted-token` meta tag.
    index: Arc<str>,
}

/// The studio's routes (see the module documentation of [`crate::studio`]),
/// behind `guard` (the checks of the module documentation of [`crate::studio`]).
pub fn router(sessions: Arc<Sessions>, access: Access) -> Router {
    let index: Arc<str> = INDEX
        .replace("{{token}}", &crate::escape::html(access.token()))
        .into();
    let app = App {
        sessions,
        access: Arc::new(access),
        index,
    };
    Router::new()
        .route("/", get(index_page))
        .route(
            "/app.js",
            get(|| async { asset(APP_JS, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/app.css",
            get(|| async { asset(APP_CSS, "text/css; charset=utf-8") }),
        )
        .route("/api/health", get(|| async { "ok" }))
        .route("/api/session", post(open_session))
        .route("/api/data", post(upload).get(data_info))
        .route("/api/view", post(view))
        .route("/api/identify", post(identify))
        .route("/api/board", post(board))
        .route("/api/delay", post(delay))
        .route("/api/validation/clear", post(clear_validation))
        .route("/api/experiments/clear", post(clear_experiments))
        .route("/api/model", get(model))
        .route("/api/report", get(report))
        .route("/api/plan", get(plan))
        .route("/api/estimation-data", get(estimation_data))
        .fallback(|| async { error(StatusCode::NOT_FOUND, "no such page or call") })
        .layer(DefaultBodyLimit::max(MAX_JSON))
        .layer(middleware::from_fn_with_state(app.clone(), guard))
        .with_state(app)
}

/// Refuses what [`Access`] refuses (and says so on stderr), answers every
/// error as JSON and adds the [`SECURITY_HEADERS`] to every answer.
async fn guard(State(app): State<App>, req: HttpRequest, next: Next) -> Response {
    let path = req.uri().path().to_string();
    let mut res = match app.access.check(&req) {
        Ok(()) => json_errors(next.run(req).await, &path).await,
        Err((status, msg)) => {
            eprintln!("lifted studio: refused {} {path}: {msg}", req.method());
            error(status, msg)
        }
    };
    let h = res.headers_mut();
    for (name, value) in SECURITY_HEADERS {
        h.insert(name, HeaderValue::from_static(value));
    }
    res
}

/// An error answer that is not JSON (axum's own rejections: 404, 405, 413,
/// a bad query) as `{"error": "…"}` with the same status.
async fn json_errors(res: Response, path: &str) -> Response {
    let status = res.status();
    let is_json = text(res.headers(), header::CONTENT_TYPE)
        .is_some_and(|c| c.starts_with("application/json"));
    if !(status.is_client_error() || status.is_server_error()) || is_json {
        return res;
    }
    if status == StatusCode::PAYLOAD_TOO_LARGE {
        return too_large(path);
    }
    let body = axum::body::to_bytes(res.into_body(), 4096)
        .await
        .unwrap_or_default();
    let msg = String::from_utf8_lossy(&body).trim().to_string();
    let msg = if msg.is_empty() {
        status.canonical_reason().unwrap_or("error").to_string()
    } else {
        msg
    };
    error(status, msg)
}

/// The 413 answer of `path`.
fn too_large(path: &str) -> Response {
    let limit = if path == "/api/data" {
        MAX_UPLOAD
    } else {
        MAX_JSON
    };
    error(
        StatusCode::PAYLOAD_TOO_LARGE,
        format!(
            "request body too large: {path} takes at most {} MiB",
            limit >> 20
        ),
    )
}

async fn index_page(State(app): State<App>) -> Response {
    Html(app.index.to_string()).into_response()
}

fn asset(body: &'static str, mime: &'static str) -> Response {
    ([(header::CONTENT_TYPE, mime)], body).into_response()
}

fn error(status: StatusCode, msg: impl std::fmt::Display) -> Response {
    (status, axum::Json(json!({ "error": msg.to_string() }))).into_response()
}

/// The session, locked. A lock poisoned by a call that panicked halfway
/// is not trusted: the session is reset (no record, no model, an empty
/// scratch directory) and the poison cleared, so later calls start clean.
pub fn lock(state: &Shared) -> MutexGuard<'_, Session> {
    match state.lock() {
        Ok(s) => s,
        Err(poisoned) => {
            let mut s = poisoned.into_inner();
            s.reset();
            state.clear_poison();
            eprintln!(
                "lifted studio: a call failed inside the studio; the session was reset \
                 (load the record again)"
            );
            s
        }
    }
}

/// Runs `f` on the session in the blocking pool.
async fn with_session<T: Send + 'static>(
    state: Shared,
    f: impl FnOnce(&mut Session) -> CliResult<T> + Send + 'static,
) -> Result<T, Response> {
    let joined = tokio::task::spawn_blocking(move || {
        let mut s = lock(&state);
        f(&mut s)
    })
    .await;
    match joined {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(error(StatusCode::BAD_REQUEST, e)),
        Err(_) => Err(error(
            StatusCode::INTERNAL_SERVER_ERROR,
            "internal error while handling the request (the studio keeps running; \
             the session was reset)",
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

/// `?name=` of an upload, `?seq=` of a model or report, `?session=` of a
/// GET without the session header (the token is checked by `guard`).
#[derive(Debug, Default, Deserialize)]
struct CallQuery {
    name: Option<String>,
    seq: Option<u64>,
    session: Option<String>,
    /// `validation`: the upload is the validation record.
    role: Option<String>,
    /// A model of the board (`GET /api/model?board=ID`).
    board: Option<u64>,
}

/// The session of a call: `X-Lifted-Session`, else `?session=`, else the
/// default session (found on the blocking pool); a session that is not
/// open is a 410 [`SESSION_EXPIRED`] answer.
#[allow(clippy::result_large_err)]
async fn session_of(app: &App, headers: &HeaderMap, q: &CallQuery) -> Result<Handle, Response> {
    opened(app, headers, q, false).await
}

/// [`session_of`], or with `open` the session made if it is not open.
#[allow(clippy::result_large_err)]
async fn opened(
    app: &App,
    headers: &HeaderMap,
    q: &CallQuery,
    open: bool,
) -> Result<Handle, Response> {
    let id = text(headers, SESSION_HEADER)
        .or(q.session.as_deref())
        .map(str::to_string);
    let sessions = app.sessions.clone();
    match tokio::task::spawn_blocking(move || sessions.get(id.as_deref(), open)).await {
        Ok(Ok(Some(h))) => Ok(h),
        Ok(Ok(None)) => Err(error(StatusCode::GONE, SESSION_EXPIRED)),
        Ok(Err(e)) => Err(error(StatusCode::BAD_REQUEST, e)),
        Err(_) => Err(error(
            StatusCode::INTERNAL_SERVER_ERROR,
            "internal error while opening the session",
        )),
    }
}

/// Streams an upload's body to `path`, at most [`MAX_UPLOAD`] bytes.
#[allow(clippy::result_large_err)]
async fn receive(headers: &HeaderMap, mut body: Body, path: &Path) -> Result<(), Response> {
    let declared = text(headers, header::CONTENT_LENGTH).and_then(|l| l.parse::<u64>().ok());
    if declared.is_some_and(|l| l > MAX_UPLOAD as u64) {
        return Err(too_large("/api/data"));
    }
    let store = |e: std::io::Error| {
        error(
            StatusCode::BAD_REQUEST,
            format!("cannot store the upload: {e}"),
        )
    };
    let mut file = std::fs::File::create(path).map_err(store)?;
    let mut total = 0usize;
    while let Some(frame) = std::future::poll_fn(|cx| Pin::new(&mut body).poll_frame(cx)).await {
        let frame =
            frame.map_err(|e| error(StatusCode::BAD_REQUEST, format!("upload cut short: {e}")))?;
        if let Ok(data) = frame.into_data() {
            total += data.len();
            if total > MAX_UPLOAD {
                return Err(too_large("/api/data"));
            }
            file.write_all(&data).map_err(store)?;
        }
    }
    file.flush().map_err(store)
}

/// `POST /api/data?name=F`: the body goes to a new folder of the scratch
/// directory (outside the lock); only once it reads whole does it replace
/// the loaded record.
async fn upload(
    State(app): State<App>,
    Query(q): Query<CallQuery>,
    headers: HeaderMap,
    body: Body,
) -> Response {
    let h = match session_of(&app, &headers, &q).await {
        Ok(h) => h,
        Err(e) => return e,
    };
    let role = match q.role.as_deref() {
        None | Some("estimation") => 0,
        Some("validation") => 1,
        Some("experiment") => 2,
        Some(other) => {
            return error(
                StatusCode::BAD_REQUEST,
                format!(
                    "role '{other}': an upload is the 'estimation' or the 'validation' record, \
                     or a further 'experiment'"
                ),
            );
        }
    };
    let name = q.name.unwrap_or_else(|| "data.csv".into());
    let (folder, path) = match staging(&h.dir, &name) {
        Ok(fp) => fp,
        Err(e) => return error(StatusCode::BAD_REQUEST, e),
    };
    if let Err(res) = receive(&headers, body, &path).await {
        let _ = std::fs::remove_dir_all(&folder);
        return res;
    }
    json_answer(
        with_session(h.session, move |s| match role {
            1 => s.adopt_validation(folder, path),
            2 => s.adopt_experiment(folder, path),
            _ => s.adopt(folder, path),
        })
        .await,
    )
}

/// `POST /api/session`: opens the tab's session (`X-Lifted-Session`),
/// seeded with the default session's record, and answers its record's
/// [`DataInfo`](crate::studio::DataInfo) (`null` without one). Opening an
/// open session keeps it as it is.
async fn open_session(State(app): State<App>, headers: HeaderMap) -> Response {
    match opened(&app, &headers, &CallQuery::default(), true).await {
        Ok(h) => json_answer(with_session(h.session, |s| Ok(s.data_info().cloned())).await),
        Err(e) => e,
    }
}

async fn data_info(
    State(app): State<App>,
    Query(q): Query<CallQuery>,
    headers: HeaderMap,
) -> Response {
    let validation = q.role.as_deref() == Some("validation");
    match session_of(&app, &headers, &q).await {
        Ok(h) => json_answer(
            with_session(h.session, move |s| {
                Ok(if validation {
                    s.validation_info().cloned()
                } else {
                    s.data_info().cloned()
                })
            })
            .await,
        ),
        Err(e) => e,
    }
}

async fn view(State(app): State<App>, headers: HeaderMap, body: Bytes) -> Response {
    match session_of(&app, &headers, &CallQuery::default()).await {
        Ok(h) => {
            json_answer(with_session(h.session, move |s| s.view(&parse_request(&body)?)).await)
        }
        Err(e) => e,
    }
}

async fn identify(State(app): State<App>, headers: HeaderMap, body: Bytes) -> Response {
    match session_of(&app, &headers, &CallQuery::default()).await {
        Ok(h) => {
            json_answer(with_session(h.session, move |s| s.identify(&parse_request(&body)?)).await)
        }
        Err(e) => e,
    }
}

/// `POST /api/board`: keep, remove and show the models of the board.
async fn board(State(app): State<App>, headers: HeaderMap, body: Bytes) -> Response {
    match session_of(&app, &headers, &CallQuery::default()).await {
        Ok(h) => json_answer(
            with_session(h.session, move |s| {
                let b: crate::studio::BoardRequest = if body.iter().all(u8::is_ascii_whitespace) {
                    Default::default()
                } else {
                    serde_json::from_slice(&body).map_err(|e| input(format!("board: {e}")))?
                };
                s.board(&b)
            })
            .await,
        ),
        Err(e) => e,
    }
}

/// `POST /api/delay`: the delay interval of every pair of the channels.
async fn delay(State(app): State<App>, headers: HeaderMap, body: Bytes) -> Response {
    match session_of(&app, &headers, &CallQuery::default()).await {
        Ok(h) => {
            json_answer(with_session(h.session, move |s| s.delays(&parse_request(&body)?)).await)
        }
        Err(e) => e,
    }
}

/// `POST /api/validation/clear`: drop the validation record.
async fn clear_validation(State(app): State<App>, headers: HeaderMap) -> Response {
    match session_of(&app, &headers, &CallQuery::default()).await {
        Ok(h) => json_answer(
            with_session(h.session, |s| {
                s.clear_validation();
                Ok(serde_json::Value::Null)
            })
            .await,
        ),
        Err(e) => e,
    }
}

/// `POST /api/experiments/clear`: drop the further experiments.
async fn clear_experiments(State(app): State<App>, headers: HeaderMap) -> Response {
    match session_of(&app, &headers, &CallQuery::default()).await {
        Ok(h) => json_answer(
            with_session(h.session, |s| {
                s.clear_experiments();
                Ok(serde_json::Value::Null)
            })
            .await,
        ),
        Err(e) => e,
    }
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

/// `GET /api/model[?seq=N]`: the model of request N (the last without).
async fn model(State(app): State<App>, Query(q): Query<CallQuery>, headers: HeaderMap) -> Response {
    let h = match session_of(&app, &headers, &q).await {
        Ok(h) => h,
        Err(e) => return e,
    };
    let board = q.board;
    match with_session(h.session, move |s| match board {
        Some(id) => s.board_model_json(id),
        None => s.model_json(q.seq),
    })
    .await
    {
        Ok(j) => download(j, "application/json", "model.json"),
        Err(e) => e,
    }
}

/// `GET /api/plan[?seq=N]`: the plan of the model of request N (the last
/// without): its workflow options, as `lifted identify --write-plan`
/// writes them.
async fn plan(State(app): State<App>, Query(q): Query<CallQuery>, headers: HeaderMap) -> Response {
    let h = match session_of(&app, &headers, &q).await {
        Ok(h) => h,
        Err(e) => return e,
    };
    match with_session(h.session, move |s| s.plan_json(q.seq)).await {
        Ok(j) => download(j, "application/json", "plan.json"),
        Err(e) => e,
    }
}

/// `GET /api/estimation-data[?seq=N]`: the data file the command line of
/// model N names (the record, or the rows of its estimation range).
async fn estimation_data(
    State(app): State<App>,
    Query(q): Query<CallQuery>,
    headers: HeaderMap,
) -> Response {
    let h = match session_of(&app, &headers, &q).await {
        Ok(h) => h,
        Err(e) => return e,
    };
    match with_session(h.session, move |s| s.estimation_data(q.seq)).await {
        Ok((name, text)) => (
            [
                (header::CONTENT_TYPE, "text/csv; charset=utf-8".to_string()),
                (
                    header::CONTENT_DISPOSITION,
                    format!("attachment; filename=\"{name}\""),
                ),
            ],
            text,
        )
            .into_response(),
        Err(e) => e,
    }
}

/// `GET /api/report[?seq=N]`: the report of the model of request N.
async fn report(
    State(app): State<App>,
    Query(q): Query<CallQuery>,
    headers: HeaderMap,
) -> Response {
    let h = match session_of(&app, &headers, &q).await {
        Ok(h) => h,
        Err(e) => return e,
    };
    match with_session(h.session, move |s| s.report(q.seq)).await {
        Ok(h) => download(h, "text/html; charset=utf-8", "report.html"),
        Err(e) => e,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_poisoned_session_is_reset_not_reused() {
        let parent = std::env::temp_dir();
        let mut s = Session::new(&parent).unwrap();
        s.upload("rec.csv", b"t,u1,y1\n0,1,2\n0.1,-1,3\n").unwrap();
        let dir = s.dir().to_path_buf();
        let shared: Shared = Arc::new(Mutex::new(s));
        let poison = shared.clone();
        let _ = std::thread::spawn(move || {
            let _held = poison.lock().unwrap();
            panic!("a call fails halfway");
        })
        .join();
        assert!(shared.is_poisoned());
        {
            let s = lock(&shared);
            assert!(s.data_info().is_none());
            assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        }
        assert!(!shared.is_poisoned());
    }

    #[test]
    fn hosts_and_tokens() {
        let a = Access::new(8123).unwrap();
        assert_eq!(a.token().len(), 64);
        assert_ne!(a.token(), Access::new(8123).unwrap().token());
        for ok in [
            "127.0.0.1:8123",
            "localhost:8123",
            "LOCALHOST:8123",
            "[::1]:8123",
        ] {
            assert!(a.host_ok(ok), "{ok}");
        }
        for bad in [
            "evil.example",
            "evil.example:8123",
            "127.0.0.1",
            "127.0.0.1:80",
            "localhost",
        ] {
            assert!(!a.host_ok(bad), "{bad}");
        }
        assert!(a.token_ok(a.token().as_bytes()));
        assert!(!a.token_ok(b""));
        assert!(!a.token_ok(&a.token().as_bytes()[1..]));
    }
}
