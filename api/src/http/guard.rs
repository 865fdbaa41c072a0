//! The guard in front of every route: the `Host` check, the body read within its timeout and
//! limit before a request slot is taken, and the request gate (`/healthz` and `/readyz` stay
//! outside it).

use super::*;

/// Whether a `Host` header value names this server: a loopback name or one of `allowed`,
/// with any port. A request without `Host` (HTTP/1.0) passes: browsers always send one.
pub(super) fn host_allowed(host: Option<&HeaderValue>, allowed: &[String]) -> bool {
    let Some(host) = host else {
        return true;
    };
    let Ok(host) = host.to_str() else {
        return false;
    };
    let host = host.trim().to_ascii_lowercase();
    // strip the port: `name:port`, `[v6]:port`, `[v6]`
    let name = if let Some(rest) = host.strip_prefix('[') {
        match rest.split_once(']') {
            Some((v6, tail)) if tail.is_empty() || tail.starts_with(':') => format!("[{v6}]"),
            _ => return false,
        }
    } else {
        match host.rsplit_once(':') {
            Some((n, port)) if port.bytes().all(|b| b.is_ascii_digit()) => n.to_string(),
            Some(_) => return false,
            None => host.clone(),
        }
    };
    matches!(name.as_str(), "localhost" | "127.0.0.1" | "[::1]")
        || allowed.iter().any(|a| a.eq_ignore_ascii_case(&name))
}

/// In front of every route, in this order: the `Host` check (403); 413 at once for a declared
/// `Content-Length` over the limit; liveness and readiness answered outside the gate; the
/// whole body read within the body timeout (408, the connection closed) and the limit (413)
/// before a request slot is taken, so a slow sender holds none; then 503 at once when
/// `max_concurrent` requests are already in progress.
pub(super) async fn guard(
    State(state): State<AppState>,
    req: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    if !host_allowed(req.headers().get(header::HOST), &state.hosts) {
        let host = req
            .headers()
            .get(header::HOST)
            .map(|h| {
                String::from_utf8_lossy(h.as_bytes())
                    .chars()
                    .take(100)
                    .collect::<String>()
            })
            .unwrap_or_default();
        return plain_error(
            StatusCode::FORBIDDEN,
            "forbidden_host",
            format!(
                "Host {host:?} is not this server's name; use 127.0.0.1 or localhost, or start the server with --allowed-host NAME"
            ),
        );
    }
    let declared = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    if let Some(n) = declared
        && n > state.body_limit_bytes as u64
    {
        return plain_error(
            StatusCode::PAYLOAD_TOO_LARGE,
            "payload_too_large",
            format!(
                "the body is {n} bytes; this server takes {} at most (--body-limit-bytes)",
                state.body_limit_bytes
            ),
        );
    }
    let path = req.uri().path();
    if path == "/healthz" || path == "/readyz" {
        return next.run(req).await;
    }
    let (parts, body) = req.into_parts();
    let read = axum::body::to_bytes(body, state.body_limit_bytes);
    let bytes = match tokio::time::timeout(state.body_timeout, read).await {
        Ok(Ok(b)) => b,
        Ok(Err(_)) => {
            return plain_error(
                StatusCode::PAYLOAD_TOO_LARGE,
                "payload_too_large",
                format!(
                    "the body is over this server's limit of {} bytes (--body-limit-bytes), or broke off",
                    state.body_limit_bytes
                ),
            );
        }
        Err(_) => {
            let mut r = plain_error(
                StatusCode::REQUEST_TIMEOUT,
                "request_timeout",
                format!(
                    "the request body did not arrive within {:.0} s",
                    state.body_timeout.as_secs_f64()
                ),
            );
            r.headers_mut()
                .insert(header::CONNECTION, HeaderValue::from_static("close"));
            return r;
        }
    };
    let req = axum::extract::Request::from_parts(parts, axum::body::Body::from(bytes));
    let Ok(_permit) = state.inflight.clone().try_acquire_owned() else {
        return plain_error(
            StatusCode::SERVICE_UNAVAILABLE,
            "busy",
            "too many requests in progress; try again shortly".into(),
        );
    };
    next.run(req).await
}

/// The `Host` names the server answers to besides the loopback names: the bind address
/// when it is not loopback, and `--allowed-host` names.
pub(super) fn allowed_host_names(opts: &ServeOptions) -> Vec<String> {
    let mut v: Vec<String> = opts
        .allowed_hosts
        .iter()
        .map(|h| h.to_ascii_lowercase())
        .collect();
    if !opts.bind.ip().is_loopback() {
        v.push(match opts.bind.ip() {
            std::net::IpAddr::V6(a) => format!("[{a}]"),
            a => a.to_string(),
        });
    }
    v
}
