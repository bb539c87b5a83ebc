//! `sonarproj view`: the interactive viewer, a local web page served by this binary. The page and
//! its scripts (three.js included) are inside the binary; each slider move posts a scene to
//! `/api/scene`, which the engine computes here ([`sonarproj_apps::view::Viewer`]).
//!
//! A local tool, not a web service: it binds loopback unless told otherwise, answers only
//! requests whose `Host` (and `Origin`, when sent) name this server by an IP address or
//! `localhost` (so a web page elsewhere cannot reach it through DNS rebinding), reads no file the
//! browser names (sonar files come from the command line) and reads at most
//! [`MAX_REQUEST_BYTES`] of a request.

use std::io::Read;
use std::net::{IpAddr, SocketAddr};

use serde_json::json;
use sonarproj::BackendChoice;
use sonarproj_apps::view::{Choice, MAX_REQUEST_BYTES, Scene, Viewer};
use sonarproj_apps::{Error, Result};
use tiny_http::{Header, Method, Request, Response, Server};

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
const ASSETS: [Asset; 6] = [
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
    let mut viewer = Viewer::new(vec![first, second], backend, choice, gpu);

    let server = Server::http(SocketAddr::new(a.bind, a.port))
        .map_err(|e| Error::Serve(format!("cannot listen on {}:{}: {e}", a.bind, a.port)))?;
    let port = server
        .server_addr()
        .to_ip()
        .map(|s| s.port())
        .ok_or_else(|| Error::Serve("not listening on an IP address".into()))?;
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

    for request in server.incoming_requests() {
        let reply = answer(&mut viewer, &initial, port, request);
        if let Err(e) = reply {
            eprintln!("note: a reply was not sent: {e}");
        }
    }
    Ok(())
}

/// Returns true when `host` (a `Host` header value, or an `Origin`'s authority) names this
/// server: `localhost` or an IP address, with this server's port. A DNS name other than
/// `localhost` is refused, which is what stops DNS rebinding.
fn allowed_host(host: &str, port: u16) -> bool {
    let Some((name, p)) = host.rsplit_once(':') else {
        return false;
    };
    if p.parse::<u16>().ok() != Some(port) {
        return false;
    }
    let name = name
        .strip_prefix('[')
        .and_then(|n| n.strip_suffix(']'))
        .unwrap_or(name);
    name.eq_ignore_ascii_case("localhost") || name.parse::<IpAddr>().is_ok()
}

/// Returns why `request` is refused (403), or `None` when its `Host` and `Origin` are ours.
fn refused(request: &Request, port: u16) -> Option<String> {
    let header = |name: &'static str| {
        request
            .headers()
            .iter()
            .find(|h| h.field.equiv(name))
            .map(|h| h.value.as_str().to_string())
    };
    let host = header("Host").unwrap_or_default();
    if !allowed_host(&host, port) {
        return Some(format!(
            "Host {host:?} is not this viewer (use http://127.0.0.1:{port}/)"
        ));
    }
    if let Some(origin) = header("Origin") {
        let ok = origin
            .strip_prefix("http://")
            .is_some_and(|o| o.eq_ignore_ascii_case(&host) && allowed_host(o, port));
        if !ok {
            return Some(format!("Origin {origin:?} is not this viewer"));
        }
    }
    None
}

/// Returns a header; the names and values are fixed ASCII.
fn header(name: &str, value: &str) -> Header {
    Header::from_bytes(name.as_bytes(), value.as_bytes()).expect("ASCII header")
}

/// Returns `body` as a response with `status` and `content_type`, and the headers every reply
/// carries (no caching, no sniffing, the page's content security policy).
fn reply(status: u16, content_type: &str, body: Vec<u8>) -> Response<std::io::Cursor<Vec<u8>>> {
    Response::from_data(body)
        .with_status_code(status)
        .with_header(header("Content-Type", content_type))
        .with_header(header("Cache-Control", "no-store"))
        .with_header(header("X-Content-Type-Options", "nosniff"))
        .with_header(header("Referrer-Policy", "no-referrer"))
        .with_header(header("Content-Security-Policy", CSP))
}

/// Returns a JSON reply.
fn json_reply(status: u16, value: &serde_json::Value) -> Response<std::io::Cursor<Vec<u8>>> {
    reply(
        status,
        "application/json",
        serde_json::to_vec(value).expect("plain JSON values"),
    )
}

/// Returns a JSON error reply: `{"error": message, "input": is_input}`.
fn error_reply(status: u16, message: &str, input: bool) -> Response<std::io::Cursor<Vec<u8>>> {
    json_reply(status, &json!({ "error": message, "input": input }))
}

/// Answers one request.
fn answer(
    viewer: &mut Viewer,
    initial: &serde_json::Value,
    port: u16,
    mut request: Request,
) -> std::io::Result<()> {
    if let Some(why) = refused(&request, port) {
        return request.respond(error_reply(403, &why, true));
    }
    let path = request.url().split('?').next().unwrap_or("/").to_string();
    let path = if path == "/index.html" { "/" } else { &path };
    let response = match (request.method(), path) {
        (Method::Get | Method::Head, "/api/init") => {
            let mut init = viewer.init();
            init["initial"] = initial.clone();
            json_reply(200, &init)
        }
        (Method::Post, "/api/scene") => {
            let mut body = Vec::new();
            let limit = u64::try_from(MAX_REQUEST_BYTES).expect("small") + 1;
            match request.as_reader().take(limit).read_to_end(&mut body) {
                Err(e) => error_reply(400, &format!("cannot read the request: {e}"), true),
                Ok(_) => match Scene::parse(&body).and_then(|s| viewer.scene(&s)) {
                    Ok(v) => json_reply(200, &v),
                    Err(e) => error_reply(if e.is_input() { 400 } else { 500 }, &e.to_string(), e.is_input()),
                },
            }
        }
        (Method::Get | Method::Head, p) => match ASSETS.iter().find(|(name, _, _)| *name == p) {
            Some((_, kind, bytes)) => reply(200, kind, bytes.to_vec()),
            None => error_reply(404, &format!("no such page: {p}"), true),
        },
        (m, p) => error_reply(405, &format!("{m} {p} is not served"), true),
    };
    request.respond(response)
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
        for bad in [
            "127.0.0.1:8766",
            "evil.example:8765",
            "localhost.evil.example:8765",
            "127.0.0.1",
            "",
            "[::1]",
            "localhost:",
            "127.0.0.1.nip.io:8765",
        ] {
            assert!(!allowed_host(bad, 8765), "{bad}");
        }
    }
}
