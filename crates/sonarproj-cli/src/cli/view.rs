//! `sonarproj view`: the interactive viewer, a local web page served by this binary. The page
//! and its scripts (three.js included) live inside the binary. Each slider move posts a scene
//! to `/api/scene`, which the engine computes here ([`sonarproj_apps::view::Viewer`]).
//!
//! It is a local tool, not a web service. It binds loopback unless told otherwise. It answers
//! only requests whose one `Host` (and `Origin`, when sent) names this server by an IP address
//! or `localhost`, so a web page elsewhere cannot reach it through DNS rebinding. It reads no
//! file the browser names: sonar files come from the command line.
//!
//! Limits keep any one client from exhausting the server:
//! - hyper (HTTP/1 on tokio) bounds the request head: [`MAX_HEAD_BYTES`] and [`MAX_HEADERS`]
//!   (431 past them), [`HEAD_TIMEOUT`] (then the connection closes), and one `Content-Length`
//!   (400 for conflicting ones).
//! - A body must arrive within [`BODY_TIMEOUT`] and hold at most [`MAX_REQUEST_BYTES`] (413).
//! - A client that stops reading a reply for [`WRITE_TIMEOUT`] is dropped.
//! - Each connection is its own task, so a slow client stalls nobody else.
//! - Scenes run on blocking threads, at most [`computing`] at once with [`MAX_WAITING`] more
//!   queued (503 past them). Each holds its slots until its work ends. When its client goes
//!   away, the work stops at the next stage (on the fast CPU path, the next pose or tile).
//!
//! Every error reply is a short JSON object.

use sonarproj::stream::Stop;
use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use http_body_util::{BodyExt, Full, LengthLimitError, Limited};
use hyper::body::{Bytes, Incoming};
use hyper::header::{HOST, HeaderValue, ORIGIN};
use hyper::{Method, Request, Response, StatusCode};
use serde_json::json;
use sonarproj::BackendChoice;
use sonarproj_apps::view::advise::AdviseRequest;
use sonarproj_apps::view::{Choice, MAX_REQUEST_BYTES, Scene, Viewer};
use sonarproj_apps::{Error, Result};
use tokio::sync::Semaphore;

use super::BackendArg;

/// Options of `sonarproj view`.
#[derive(Debug, clap::Args)]
pub(super) struct ViewArgs {
    /// Port to listen on (0: any free port; the address is printed).
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// Address to listen on. The default, 127.0.0.1, lets only this machine in; anything else
    /// opens the viewer (and the machine's CPU or GPU) to the network.
    #[arg(long, value_name = "IP", default_value = "127.0.0.1")]
    bind: IpAddr,
    /// Sonar 1 shown first: a preset name or a sonar TOML file (a file is offered beside the
    /// presets; the page cannot open files itself).
    #[arg(long, value_name = "SONAR", default_value = "paper-fls")]
    from: String,
    /// Sonar 2 shown first: a preset name or a sonar TOML file.
    #[arg(long, value_name = "SONAR", default_value = "paper-sss")]
    to: String,
    /// Open the page in the default browser.
    #[arg(long)]
    open: bool,
    /// Where to compute: auto picks a hardware GPU when one exists, else the fast CPU path.
    #[arg(long, value_enum, default_value = "auto")]
    backend: BackendArg,
}

/// One file of the page: path, content type, bytes.
type Asset = (&'static str, &'static str, &'static [u8]);

/// The page's files, served from inside the binary.
const ASSETS: [Asset; 7] = [
    (
        "/",
        "text/html; charset=utf-8",
        include_bytes!("../../../../web/viewer/index.html"),
    ),
    (
        "/app.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../../../web/viewer/app.js"),
    ),
    (
        "/advise.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../../../web/viewer/advise.js"),
    ),
    (
        "/style.css",
        "text/css; charset=utf-8",
        include_bytes!("../../../../web/viewer/style.css"),
    ),
    (
        "/vendor/three/three.module.min.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../../../web/viewer/vendor/three/three.module.min.js"),
    ),
    (
        "/vendor/three/three.core.min.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../../../web/viewer/vendor/three/three.core.min.js"),
    ),
    (
        "/vendor/three/OrbitControls.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../../../web/viewer/vendor/three/OrbitControls.js"),
    ),
];

/// The page may load its own files and talk to this server only.
const CSP: &str = "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; \
                   img-src 'self' data: blob:; connect-src 'self'; frame-ancestors 'none'; \
                   base-uri 'none'; form-action 'none'";

/// The most bytes of a request's head (request line and headers).
pub(crate) const MAX_HEAD_BYTES: usize = 64 * 1024;
/// The most headers of a request.
pub(crate) const MAX_HEADERS: usize = 64;
/// The time a client has to send a request's head, and then its body.
pub(crate) const HEAD_TIMEOUT: Duration = Duration::from_secs(10);
pub(crate) const BODY_TIMEOUT: Duration = Duration::from_secs(10);
/// The time a client has to take each part of a reply, before the connection ends.
pub(crate) const WRITE_TIMEOUT: Duration = Duration::from_secs(30);
/// The most connections served at once. More wait to be accepted.
const MAX_CONNECTIONS: usize = 256;
/// The most scenes waiting for a computing slot. More are answered 503 at once.
const MAX_WAITING: usize = 16;
/// The most characters of a path an error reply quotes.
const QUOTED_PATH_CHARS: usize = 80;

/// Returns how many scenes are computed at once: the cores, from 2 to 8. Each scene's
/// projection already uses every core, so more at once would only share them.
fn computing() -> usize {
    std::thread::available_parallelism().map_or(2, |n| n.get().clamp(2, 8))
}

/// What every request's task shares.
struct Shared {
    viewer: Viewer,
    initial: serde_json::Value,
    port: u16,
    /// Slots to compute a scene in, and slots to wait for one in. A scene holds its slots until
    /// its work has ended, even when its client left before.
    computing: Arc<Semaphore>,
    waiting: Arc<Semaphore>,
}

/// Runs `sonarproj view` until interrupted.
pub(super) fn run(a: ViewArgs) -> Result<()> {
    let first = Choice::resolve(&a.from).map_err(|e| e.in_context("--from"))?;
    let second = Choice::resolve(&a.to).map_err(|e| e.in_context("--to"))?;
    let choice: BackendChoice = a.backend.into();
    let gpu = super::gpu_env::options_for(choice)?;
    let (backend, notice) = super::gpu_env::select(choice)?;
    if let Some(n) = notice {
        eprintln!("{n}");
    }
    let initial = json!({ "from": first.label, "to": second.label });
    let viewer = Viewer::new(vec![first, second], backend, choice, gpu);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_io()
        .enable_time()
        .thread_name("sonarproj-view")
        .build()
        .map_err(|e| Error::Serve(format!("cannot start the server's runtime: {e}")))?;
    runtime.block_on(serve(a, viewer, initial))
}

/// Listens and serves until the process is stopped.
async fn serve(a: ViewArgs, viewer: Viewer, initial: serde_json::Value) -> Result<()> {
    let listener = tokio::net::TcpListener::bind(SocketAddr::new(a.bind, a.port))
        .await
        .map_err(|e| Error::Serve(format!("cannot listen on {}:{}: {e}", a.bind, a.port)))?;
    let port = listener
        .local_addr()
        .map_err(|e| Error::Serve(format!("no local address: {e}")))?
        .port();
    let shown_host = match a.bind {
        IpAddr::V4(v) if v.is_unspecified() => "127.0.0.1".to_string(),
        IpAddr::V6(v) if v.is_unspecified() => "[::1]".to_string(),
        IpAddr::V6(v) => format!("[{v}]"),
        IpAddr::V4(v) => v.to_string(),
    };
    let url = format!("http://{shown_host}:{port}/");
    outln!(
        "sonarproj view: {url} (computing on {}; Ctrl-C stops it)",
        viewer.device().1
    )?;
    if a.open
        && let Err(e) = open::that_detached(&url)
    {
        eprintln!("note: could not open a browser ({e}); open {url} yourself");
    }
    let shared = Arc::new(Shared {
        viewer,
        initial,
        port,
        computing: Arc::new(Semaphore::new(computing())),
        waiting: Arc::new(Semaphore::new(computing() + MAX_WAITING)),
    });
    let connections = Arc::new(Semaphore::new(MAX_CONNECTIONS));
    loop {
        let Ok(permit) = Arc::clone(&connections).acquire_owned().await else {
            return Ok(());
        };
        let (stream, _) = match listener.accept().await {
            Ok(c) => c,
            Err(e) => {
                eprintln!("note: a connection was not accepted: {e}");
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
        };
        let shared = Arc::clone(&shared);
        tokio::spawn(async move {
            let service = hyper::service::service_fn(move |request| {
                let shared = Arc::clone(&shared);
                async move { Ok::<_, std::convert::Infallible>(answer(&shared, request).await) }
            });
            let mut http = hyper::server::conn::http1::Builder::new();
            http.timer(hyper_util::rt::TokioTimer::new())
                .header_read_timeout(HEAD_TIMEOUT)
                .max_buf_size(MAX_HEAD_BYTES)
                .max_headers(MAX_HEADERS);
            // An error here is the client's (it left, or sent a bad or slow head), and hyper has
            // answered what it could. A client that stops reading a reply is dropped after
            // WRITE_TIMEOUT, so it cannot hold its connection slot forever.
            let mut stream = tokio_io_timeout::TimeoutStream::new(stream);
            stream.set_write_timeout(Some(WRITE_TIMEOUT));
            let _ = http
                .serve_connection(hyper_util::rt::TokioIo::new(Box::pin(stream)), service)
                .await;
            drop(permit);
        });
    }
}

/// Returns true when `host` (a `Host` header value, or an `Origin`'s authority) names this
/// server: `localhost` or an IP address, with this server's port. A DNS name other than
/// `localhost` is refused, which is what stops DNS rebinding.
fn allowed_host(host: &str, port: u16) -> bool {
    // Browsers leave the default port out: `localhost` or `[::1]` alone mean port 80.
    let (name, p) = match host.rsplit_once(':') {
        Some((name, p)) if !p.contains(']') => (name, Some(p)),
        _ => (host, None),
    };
    let given = match p {
        Some(p) => p.parse::<u16>().ok(),
        None => Some(80),
    };
    if given != Some(port) {
        return false;
    }
    let name = name
        .strip_prefix('[')
        .and_then(|n| n.strip_suffix(']'))
        .unwrap_or(name);
    name.eq_ignore_ascii_case("localhost") || name.parse::<IpAddr>().is_ok()
}

/// Returns why `request` is refused, with its status: 400 for a doubled header, 403 for a
/// foreign one. `None` when its one `Host` and its `Origin` are ours.
fn refused(request: &Request<Incoming>, port: u16) -> Option<(StatusCode, String)> {
    let one = |name: hyper::header::HeaderName, shown: &str| {
        let mut all = request.headers().get_all(&name).iter();
        match (all.next(), all.next()) {
            (Some(v), None) => Ok(Some(v.to_str().unwrap_or("").to_string())),
            (None, _) => Ok(None),
            (Some(_), Some(_)) => Err((StatusCode::BAD_REQUEST, format!("more than one {shown} header"))),
        }
    };
    let host = match one(HOST, "Host") {
        Ok(h) => h.unwrap_or_default(),
        Err(e) => return Some(e),
    };
    if !allowed_host(&host, port) {
        return Some((
            StatusCode::FORBIDDEN,
            format!(
                "Host {} is not this viewer (use http://127.0.0.1:{port}/)",
                quoted(&host)
            ),
        ));
    }
    match one(ORIGIN, "Origin") {
        Err(e) => Some(e),
        Ok(Some(origin)) => {
            let ok = origin
                .strip_prefix("http://")
                .is_some_and(|o| o.eq_ignore_ascii_case(&host) && allowed_host(o, port));
            (!ok).then(|| {
                (
                    StatusCode::FORBIDDEN,
                    format!("Origin {} is not this viewer", quoted(&origin)),
                )
            })
        }
        Ok(None) => None,
    }
}

/// Returns `text` quoted for an error reply, cut to [`QUOTED_PATH_CHARS`] characters.
fn quoted(text: &str) -> String {
    match text.char_indices().nth(QUOTED_PATH_CHARS) {
        None => format!("{text:?}"),
        Some((at, _)) => format!("{:?}… ({} bytes)", &text[..at], text.len()),
    }
}

/// Returns `body` as a response with `status` and `content_type`, plus the headers of every
/// reply: no caching, no sniffing, and the page's content security policy.
fn reply(status: StatusCode, content_type: &'static str, body: Bytes) -> Response<Full<Bytes>> {
    let mut r = Response::new(Full::new(body));
    *r.status_mut() = status;
    let h = r.headers_mut();
    for (name, value) in [
        ("content-type", content_type),
        ("cache-control", "no-store"),
        ("x-content-type-options", "nosniff"),
        ("referrer-policy", "no-referrer"),
        ("content-security-policy", CSP),
    ] {
        h.insert(name, HeaderValue::from_static(value));
    }
    r
}

fn json_reply(status: StatusCode, value: &serde_json::Value) -> Response<Full<Bytes>> {
    reply(
        status,
        "application/json",
        Bytes::from(serde_json::to_vec(value).expect("plain JSON values")),
    )
}

/// Returns a JSON error reply: `{"error": message, "input": is_input}`.
fn error_reply(status: StatusCode, message: &str, input: bool) -> Response<Full<Bytes>> {
    json_reply(status, &json!({ "error": message, "input": input }))
}

/// Sets its flag when dropped: the request finished, or its future was dropped because the
/// client went away. The scene's blocking work then stops at its next stage.
struct GoneOnDrop(Arc<AtomicBool>);

impl Drop for GoneOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

async fn answer(shared: &Arc<Shared>, request: Request<Incoming>) -> Response<Full<Bytes>> {
    if let Some((status, why)) = refused(&request, shared.port) {
        return error_reply(status, &why, true);
    }
    let path = request.uri().path();
    let path = if path == "/index.html" { "/" } else { path };
    match (request.method(), path) {
        (&Method::GET | &Method::HEAD, "/api/init") => {
            let mut init = shared.viewer.init();
            init["initial"] = shared.initial.clone();
            json_reply(StatusCode::OK, &init)
        }
        (&Method::POST, "/api/scene") => scene(shared, request).await,
        (&Method::POST, "/api/advise") => advise(shared, request).await,
        (&Method::GET | &Method::HEAD, p) => match ASSETS.iter().find(|(name, _, _)| *name == p) {
            Some((_, kind, bytes)) => reply(StatusCode::OK, kind, Bytes::from_static(bytes)),
            None => error_reply(
                StatusCode::NOT_FOUND,
                &format!("no such page: {}", quoted(p)),
                true,
            ),
        },
        (m, p) => error_reply(
            StatusCode::METHOD_NOT_ALLOWED,
            &format!("{m} {} is not served", quoted(p)),
            true,
        ),
    }
}

/// Returns the request's body, read within the size and time bounds, or the error reply.
async fn body_of(request: Request<Incoming>) -> std::result::Result<Bytes, Response<Full<Bytes>>> {
    let body = Limited::new(request.into_body(), MAX_REQUEST_BYTES);
    match tokio::time::timeout(BODY_TIMEOUT, body.collect()).await {
        Err(_) => Err(error_reply(
            StatusCode::REQUEST_TIMEOUT,
            &format!(
                "request: the body did not arrive within {} s",
                BODY_TIMEOUT.as_secs()
            ),
            true,
        )),
        Ok(Err(e)) if e.downcast_ref::<LengthLimitError>().is_some() => Err(error_reply(
            StatusCode::PAYLOAD_TOO_LARGE,
            &format!("request: at most {MAX_REQUEST_BYTES} bytes"),
            true,
        )),
        Ok(Err(e)) => Err(error_reply(
            StatusCode::BAD_REQUEST,
            &format!("cannot read the request: {e}"),
            true,
        )),
        Ok(Ok(collected)) => Ok(collected.to_bytes()),
    }
}

/// Answers `POST /api/scene`: reads the body (bounded in size and time), waits for a computing
/// slot (bounded queue), and computes the scene on a blocking thread.
async fn scene(shared: &Arc<Shared>, request: Request<Incoming>) -> Response<Full<Bytes>> {
    let body = match body_of(request).await {
        Ok(b) => b,
        Err(reply) => return reply,
    };
    let scene = match Scene::parse(&body) {
        Ok(s) => s,
        Err(e) => return error_reply(StatusCode::BAD_REQUEST, &e.to_string(), true),
    };
    compute(shared, move |viewer, gone| {
        let gone = || gone.load(Ordering::Relaxed);
        viewer.scene_until(&scene, Stop::when(&gone))
    })
    .await
}

/// Answers `POST /api/advise` (the advise panel) as `scene` answers a scene.
async fn advise(shared: &Arc<Shared>, request: Request<Incoming>) -> Response<Full<Bytes>> {
    let body = match body_of(request).await {
        Ok(b) => b,
        Err(reply) => return reply,
    };
    let asked = match AdviseRequest::parse(&body) {
        Ok(a) => a,
        Err(e) => return error_reply(StatusCode::BAD_REQUEST, &e.to_string(), true),
    };
    compute(shared, move |viewer, gone| {
        // Given up, as a scene is, once the client has gone.
        let gone = || gone.load(Ordering::Relaxed);
        viewer.advise_until(&asked, Stop::when(&gone))
    })
    .await
}

/// Runs `work` on a blocking thread once a computing slot is free, and replies with its JSON
/// or its error (400 for bad input). Waiting requests form a bounded queue, then get 503.
/// `work` gets a flag that is set when the client goes away.
async fn compute(
    shared: &Arc<Shared>,
    work: impl FnOnce(&Viewer, &AtomicBool) -> sonarproj_apps::Result<serde_json::Value> + Send + 'static,
) -> Response<Full<Bytes>> {
    let Ok(waiting) = Arc::clone(&shared.waiting).try_acquire_owned() else {
        return error_reply(
            StatusCode::SERVICE_UNAVAILABLE,
            "busy: too many scenes are waiting; try again",
            false,
        );
    };
    let Ok(computing) = Arc::clone(&shared.computing).acquire_owned().await else {
        return error_reply(StatusCode::SERVICE_UNAVAILABLE, "the server is stopping", false);
    };
    let gone = Arc::new(AtomicBool::new(false));
    let _guard = GoneOnDrop(Arc::clone(&gone));
    let shared = Arc::clone(shared);
    let computed = tokio::task::spawn_blocking(move || {
        let slots = (waiting, computing);
        let answer = work(&shared.viewer, &gone);
        drop(slots);
        answer
    })
    .await;
    match computed {
        Ok(Ok(v)) => json_reply(StatusCode::OK, &v),
        Ok(Err(e)) => {
            let status = if e.is_input() {
                StatusCode::BAD_REQUEST
            } else {
                StatusCode::INTERNAL_SERVER_ERROR
            };
            error_reply(status, &e.to_string(), e.is_input())
        }
        Err(e) => error_reply(
            StatusCode::INTERNAL_SERVER_ERROR,
            &format!("the computation failed: {e}"),
            false,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::allowed_host;

    #[test]
    fn only_local_names_and_ip_addresses_with_our_port_are_allowed() {
        for ok in [
            "127.0.0.1:8765",
            "localhost:8765",
            "LOCALHOST:8765",
            "[::1]:8765",
            "192.168.1.4:8765",
        ] {
            assert!(allowed_host(ok, 8765), "{ok}");
        }
        // The default port, left out as browsers do.
        for ok in ["localhost", "127.0.0.1", "[::1]", "localhost:80"] {
            assert!(allowed_host(ok, 80), "{ok} on port 80");
        }
        assert!(!allowed_host("evil.example", 80) && !allowed_host("localhost", 8765));
        for bad in [
            "127.0.0.1:8766",
            "evil.example:8765",
            "localhost.evil.example:8765",
            "",
            "localhost:",
            "127.0.0.1.nip.io:8765",
        ] {
            assert!(!allowed_host(bad, 8765), "{bad}");
        }
    }
}
