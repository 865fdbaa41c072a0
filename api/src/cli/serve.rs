//! `opengraph serve`: the HTTP server (viewer, JSON API, MCP at /mcp) over one map.

use std::path::PathBuf;

use super::args::{Command, LlmArgs, ZenohArgs};
use super::common::*;

/// `opengraph serve`'s arguments.
pub(crate) struct ServeArgs {
    pub(crate) db: PathBuf,
    pub(crate) bind: std::net::SocketAddr,
    pub(crate) token_file: Option<PathBuf>,
    pub(crate) read_only: bool,
    pub(crate) workers: Option<usize>,
    pub(crate) timeout_secs: f64,
    pub(crate) body_limit_bytes: usize,
    pub(crate) max_concurrent: usize,
    pub(crate) embedding_cache: u32,
    pub(crate) query_cache: u32,
    pub(crate) cors_origin: Vec<String>,
    pub(crate) allowed_host: Vec<String>,
    pub(crate) client_timeout_secs: f64,
    pub(crate) max_connections: usize,
    pub(crate) max_connections_per_client: usize,
    pub(crate) llm: LlmArgs,
    pub(crate) zenoh: ZenohArgs,
}

/// The environment variable that can hold the write token instead of `--token-file`.
pub(crate) const TOKEN_ENV: &str = "OPENGRAPH_TOKEN";

/// Reads a write token from a file: trimmed, 16 characters or more, printable ASCII.
pub(crate) fn read_token(path: &std::path::Path) -> anyhow::Result<String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| UsageError(format!("reading the token file {}: {e}", path.display())))?;
    checked_token(
        &text,
        &format!("the token in {}", path.display()),
        &format!("openssl rand -hex 32 > {}", path.display()),
    )
}

/// The write token: from `--token-file`, else from `$OPENGRAPH_TOKEN` (an empty value is
/// no token), else none. Both at once is a usage error, so it is never unclear which one
/// the server took.
pub(crate) fn write_token(token_file: Option<&std::path::Path>) -> anyhow::Result<Option<String>> {
    let from_env = match std::env::var(TOKEN_ENV) {
        Ok(v) if v.is_empty() => None,
        Ok(v) => Some(v),
        Err(std::env::VarError::NotPresent) => None,
        Err(std::env::VarError::NotUnicode(_)) => {
            return Err(UsageError(format!(
                "{TOKEN_ENV} must be 16 or more printable characters without spaces"
            ))
            .into());
        }
    };
    match (token_file, from_env) {
        (Some(p), Some(_)) => Err(UsageError(format!(
            "both --token-file {} and {TOKEN_ENV} are set: give the write token one way",
            p.display()
        ))
        .into()),
        (Some(p), None) => read_token(p).map(Some),
        (None, Some(v)) => checked_token(
            &v,
            &format!("the token in {TOKEN_ENV}"),
            &format!("export {TOKEN_ENV}=$(openssl rand -hex 32)"),
        )
        .map(Some),
        (None, None) => Ok(None),
    }
}

/// `text` trimmed, if it is 16 or more printable ASCII characters; `what` names where it
/// came from and `example` how to make a good one, for the error.
fn checked_token(text: &str, what: &str, example: &str) -> anyhow::Result<String> {
    let token = text.trim().to_string();
    if token.len() < 16 || !token.bytes().all(|b| b.is_ascii_graphic()) {
        return Err(UsageError(format!(
            "{what} must be 16 or more printable characters without spaces (e.g. `{example}`)"
        ))
        .into());
    }
    Ok(token)
}

/// `opengraph serve`: opens the map, checks every setting, then serves until Ctrl-C.
pub(crate) fn serve(a: ServeArgs) -> anyhow::Result<()> {
    if !(a.timeout_secs.is_finite() && (0.1..=3600.0).contains(&a.timeout_secs)) {
        return Err(UsageError(format!(
            "--timeout-secs must be between 0.1 and 3600 (got {})",
            a.timeout_secs
        ))
        .into());
    }
    for (name, v, max) in [
        ("--body-limit-bytes", a.body_limit_bytes, 1usize << 30),
        ("--max-concurrent", a.max_concurrent, 100_000),
        ("--workers", a.workers.unwrap_or(1), 256),
        ("--max-connections", a.max_connections, 1_000_000),
        (
            "--max-connections-per-client",
            a.max_connections_per_client,
            1_000_000,
        ),
    ] {
        if v == 0 || v > max {
            return Err(UsageError(format!("{name} must be between 1 and {max} (got {v})")).into());
        }
    }
    if !(a.client_timeout_secs.is_finite() && (0.1..=3600.0).contains(&a.client_timeout_secs)) {
        return Err(UsageError(format!(
            "--client-timeout-secs must be between 0.1 and 3600 (got {})",
            a.client_timeout_secs
        ))
        .into());
    }
    for h in &a.allowed_host {
        if h.is_empty()
            || !h
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b"-.[]:".contains(&b))
        {
            return Err(UsageError(format!(
                "--allowed-host takes a host name or address without port or scheme (got {h:?})"
            ))
            .into());
        }
    }
    let token = write_token(a.token_file.as_deref())?;
    api::http::check_bind(&a.bind, token.as_deref()).map_err(UsageError)?;
    let writes = token.is_some() && !a.read_only;
    let workers = a.workers.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(2)
            .min(8)
    });
    let live = a.zenoh.zenoh && !a.zenoh.no_live;
    if live && a.read_only {
        return Err(UsageError(
            "--zenoh maps live into the store, which --read-only forbids: add --no-live to only serve it"
                .into(),
        )
        .into());
    }
    let live_req = if live {
        Some(live_request(&a.zenoh)?)
    } else {
        None
    };
    let first = if live {
        // live ingest writes into the store (created when missing); the tools still write
        // only with the token
        let store = if a.db.exists() {
            open_store(&a.db, true)?
        } else {
            graphstore::Store::create(&a.db)
                .map_err(|e| UsageError(format!("creating {}: {e}", a.db.display())))?
        };
        let finder = {
            let r = store.read()?;
            finder_for(
                &r,
                Some(a.zenoh.embedder.clone()),
                false,
                &LlmArgs::default(),
            )?
        };
        api::tools::Toolbox::new(store, finder, writes)
    } else {
        open_toolbox(&a.db, writes)?
    };
    let embedder_name = live.then(|| a.zenoh.embedder.clone());
    let cfg = a.llm.config(llm_tools::LlmConfig::default(), "none");
    let model = if cfg.backend == "none" {
        None
    } else {
        Some(open_llm(&cfg, "serve --llm")?)
    };
    // the in-memory spatial, vector and text indexes now, not in the first request
    first.store().warm_indexes()?;
    // the readers, then (where writes are on) the writer's own toolbox, sharing one map view
    // per commit and the caches
    let service = api::builder::ServiceBuilder::new()
        .workers(workers)
        .writer(writes)
        .timeout(std::time::Duration::from_secs_f64(a.timeout_secs))
        .embedding_cache(a.embedding_cache as usize)
        .query_cache(a.query_cache as usize)
        .llm(model)
        .build(first, |store| {
            let r = store
                .read()
                .map_err(|e| api::error::ToolError::Failed(e.to_string()))?;
            finder_for(&r, embedder_name.clone(), false, &LlmArgs::default())
                .map_err(|e| api::error::ToolError::Failed(format!("{e:#}")))
        })?;
    let opts = api::http::ServeOptions {
        bind: a.bind,
        token,
        body_limit_bytes: a.body_limit_bytes,
        max_concurrent: a.max_concurrent,
        cors_origins: a.cors_origin,
        allowed_hosts: a.allowed_host,
        header_timeout: std::time::Duration::from_secs_f64(a.client_timeout_secs),
        body_timeout: std::time::Duration::from_secs_f64(a.client_timeout_secs),
        max_connections: a.max_connections,
        max_connections_per_client: a.max_connections_per_client,
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(opts.bind)
            .await
            .map_err(|e| UsageError(format!("cannot listen on {}: {e}", opts.bind)))?;
        let addr = listener.local_addr()?;
        let zenoh = if a.zenoh.zenoh {
            let map = match &a.zenoh.map_name {
                Some(m) => m.clone(),
                None => a
                    .db
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "map".into()),
            };
            let cfg = api::zenoh_front::ZenohServe {
                session: a.zenoh.session.options(),
                map,
                region: a.zenoh.region.clone(),
                live: live_req,
            };
            let svc = service.clone();
            let rt = tokio::runtime::Handle::current();
            let front = tokio::task::spawn_blocking(move || api::zenoh_front::start(svc, cfg, rt))
                .await??;
            errln!(
                "zenoh: {}/{{events,query,graph,status}}{}",
                front.prefix,
                if live { "; mapping live from the [live] topics" } else { "" }
            );
            Some(front)
        } else {
            None
        };
        let app = api::http::router(service, &opts);
        // leave a note where to reach the server: a writer's lock keeps every other process
        // out, a read-only server's keeps writers out
        let marker = Some(serving_marker(&a.db));
        if let Some(m) = &marker {
            // "writes": whether it holds the store for writing (the token's writes, or
            // live mapping); "live": whether it maps live
            let note = serde_json::json!({"url": format!("http://{addr}/"), "pid": std::process::id(), "writes": writes || live, "live": live});
            if let Err(e) = std::fs::write(m, note.to_string()) {
                errln!("note: could not write {}: {e}", m.display());
            }
        }
        outln!("serving {} on http://{addr}/ (MCP: http://{addr}/mcp; API: http://{addr}/openapi.json)", a.db.display());
        errln!(
            "{workers} workers, {}; Ctrl-C stops",
            match (writes, live) {
                (true, _) => "and a writer; writes need the token",
                (false, true) => "mapping live; the tools are read-only (writes need a --token-file)",
                (false, false) => "read-only",
            }
        );
        api::http::serve(listener, app, &opts, async {
            shutdown_signal().await;
        })
        .await?;
        if let Some(front) = zenoh {
            let report = tokio::task::spawn_blocking(move || front.stop()).await??;
            if let Some(r) = report {
                errln!(
                    "live ingest: {} frames mapped in {} commits",
                    r.frames_run,
                    r.commits
                );
            }
        }
        if let Some(m) = &marker {
            let _ = std::fs::remove_file(m);
        }
        errln!("stopped");
        anyhow::Ok(())
    })
}

/// Resolves on Ctrl-C or SIGTERM.
pub(crate) async fn shutdown_signal() {
    let ctrl_c = tokio::signal::ctrl_c();
    #[cfg(unix)]
    {
        let mut term =
            match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
                Ok(t) => t,
                Err(_) => {
                    let _ = ctrl_c.await;
                    return;
                }
            };
        tokio::select! {
            _ = ctrl_c => {},
            _ = term.recv() => {},
        }
    }
    #[cfg(not(unix))]
    {
        let _ = ctrl_c.await;
    }
}

/// `opengraph serve`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Serve {
        db,
        bind,
        token_file,
        read_only,
        workers,
        timeout_secs,
        body_limit_bytes,
        max_concurrent,
        embedding_cache,
        query_cache,
        cors_origin,
        allowed_host,
        client_timeout_secs,
        max_connections,
        max_connections_per_client,
        llm,
        zenoh,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Serve here")
    };
    serve(ServeArgs {
        db,
        bind,
        token_file,
        read_only,
        workers,
        timeout_secs,
        body_limit_bytes,
        max_concurrent,
        embedding_cache,
        query_cache,
        cors_origin,
        allowed_host,
        client_timeout_secs,
        max_connections,
        max_connections_per_client,
        llm,
        zenoh,
    })
}

/// The live ingest settings of `serve --zenoh`: the configuration file's tables (or the
/// defaults), the calibration from --calib, the embedder.
fn live_request(z: &ZenohArgs) -> anyhow::Result<api::live::LiveRequest> {
    let mut build = match &z.config {
        Some(p) => {
            ingest::build::BuildConfig::from_toml_file(p).map_err(|e| UsageError(e.to_string()))?
        }
        None => ingest::build::BuildConfig::default(),
    };
    if let Some(c) = &z.calib {
        let calib = ingest::sources::kitti::read_calib(c).map_err(|e| UsageError(e.to_string()))?;
        build.live.cam_from_velo = scene::pose::row_major(&calib.cam0_from_velo).to_vec();
    }
    if build.live.cam_from_velo.is_empty() {
        return Err(UsageError(
            "live ingest needs the LiDAR-to-camera calibration: --calib calib.txt (KITTI's Tr), or [live] cam_from_velo in --config; --no-live serves without ingest"
                .into(),
        )
        .into());
    }
    build
        .live
        .validate()
        .map_err(|e| UsageError(e.to_string()))?;
    Ok(api::live::LiveRequest {
        live: build.live.clone(),
        embedder: api::find::EmbedderChoice::from_name(&z.embedder).unwrap_or_default(),
        build,
    })
}
