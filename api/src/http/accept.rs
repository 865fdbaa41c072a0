//! The server's own accept loop (`axum::serve` has none of this): header and idle timeouts,
//! connection caps in all and per client address, refusal with 503 over a cap.

use super::*;

/// Connections open, in all and per client address.
#[derive(Default)]
pub(super) struct Connections {
    pub(super) total: usize,
    pub(super) per_client: std::collections::HashMap<std::net::IpAddr, usize>,
}

/// One open connection's place in [`Connections`], given back on drop.
pub(super) struct ConnSlot {
    pub(super) table: Arc<std::sync::Mutex<Connections>>,
    pub(super) ip: std::net::IpAddr,
}

impl Drop for ConnSlot {
    fn drop(&mut self) {
        let mut t = self
            .table
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        t.total = t.total.saturating_sub(1);
        if let Some(n) = t.per_client.get_mut(&self.ip) {
            *n -= 1;
            if *n == 0 {
                t.per_client.remove(&self.ip);
            }
        }
    }
}

/// A place for a new connection from `ip`, or why not.
pub(super) fn take_slot(
    table: &Arc<std::sync::Mutex<Connections>>,
    ip: std::net::IpAddr,
    opts: &ServeOptions,
) -> Result<ConnSlot, &'static str> {
    let mut t = table
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if t.total >= opts.max_connections {
        return Err("too many open connections");
    }
    let mine = t.per_client.get(&ip).copied().unwrap_or(0);
    if mine >= opts.max_connections_per_client {
        return Err("too many open connections from this address");
    }
    t.total += 1;
    *t.per_client.entry(ip).or_insert(0) += 1;
    Ok(ConnSlot {
        table: table.clone(),
        ip,
    })
}

/// Serves until `shutdown` resolves, with the connection limits and the header timeout of
/// `opts` (the body timeout and the request gate are the router's, see [`router`]). A
/// connection over a limit is answered 503 and closed at once. On shutdown, connections
/// finish the request they are serving (10 s at most).
///
/// # Errors
/// The listener fails.
pub async fn serve(
    listener: tokio::net::TcpListener,
    app: Router,
    opts: &ServeOptions,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let table = Arc::new(std::sync::Mutex::new(Connections::default()));
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    let mut tasks = tokio::task::JoinSet::new();
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(hyper_util::rt::TokioTimer::new())
        .header_read_timeout(opts.header_timeout)
        // a client that sends its request and closes its sending side still gets the answer
        .half_close(true)
        .keep_alive(true);
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(a) => a,
                // out of file descriptors and the like: wait, do not spin or stop serving
                Err(e) => {
                    tracing::warn!("accept failed: {e}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        // reap finished connection tasks so the set does not grow
        while tasks.try_join_next().is_some() {}
        let slot = match take_slot(&table, peer.ip(), opts) {
            Ok(s) => s,
            Err(why) => {
                tasks.spawn(refuse_connection(stream, why));
                continue;
            }
        };
        let _ = stream.set_nodelay(true);
        let service = hyper_util::service::TowerToHyperService::new(app.clone());
        let conn = http.serve_connection(hyper_util::rt::TokioIo::new(stream), service);
        let mut stop = stop_rx.clone();
        tasks.spawn(async move {
            let _slot = slot;
            let mut conn = std::pin::pin!(conn);
            tokio::select! {
                _ = conn.as_mut() => {}
                _ = stop.changed() => {
                    conn.as_mut().graceful_shutdown();
                    let _ = tokio::time::timeout(Duration::from_secs(10), conn).await;
                }
            }
        });
    }
    let _ = stop_tx.send(true);
    let _ = tokio::time::timeout(Duration::from_secs(11), async {
        while tasks.join_next().await.is_some() {}
    })
    .await;
    Ok(())
}

/// Answers a connection over a limit with 503 and closes it (1 s at most to write).
async fn refuse_connection(mut stream: tokio::net::TcpStream, why: &'static str) {
    use tokio::io::AsyncWriteExt;
    let body = json!({"error": {"code": "busy", "message": format!("{why}; try again shortly")}})
        .to_string();
    let msg = format!(
        "HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/json\r\ncontent-length: {}\r\nconnection: close\r\n\r\n{body}",
        body.len()
    );
    let _ = tokio::time::timeout(Duration::from_secs(1), async {
        let _ = stream.write_all(msg.as_bytes()).await;
        let _ = stream.shutdown().await;
    })
    .await;
}
