//! Live ingest inside a running service: the live build ([`ingest::build::run_live`]) on a
//! thread of its own, writing into the service's store while the service serves it, its
//! commits published as events on the service's bus. Transport-free: the adapter that
//! carries the sensor messages (zenoh) receives the input side in `on_ready` and feeds it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use ingest::build::{BuildConfig, BuildReport};
use ingest::sources::live::{LiveConfig, LiveInput, LiveStats};

use crate::error::{ToolError, ToolResult, classify};
use crate::find::EmbedderChoice;
use crate::service::Service;

/// What live ingest runs with.
#[derive(Debug, Clone, Default)]
pub struct LiveRequest {
    /// Mapping, dynamic filter and hierarchy settings (`[mapping]`, `[dynamic]`,
    /// `[hierarchy]` of a build configuration).
    pub build: BuildConfig,
    /// Topics, frames, calibration and timing (`[live]`).
    pub live: LiveConfig,
    /// The sentence embedder for captions.
    pub embedder: EmbedderChoice,
}

/// Live ingest under way; [`LiveHandle::stop`] ends it.
#[derive(Debug)]
pub struct LiveHandle {
    stop: Arc<AtomicBool>,
    input: Arc<Mutex<Option<Arc<LiveInput>>>>,
    thread: Option<std::thread::JoinHandle<ToolResult<BuildReport>>>,
    /// The service whose `info` shows the counts until [`LiveHandle::stop`].
    service: Option<Arc<Service>>,
}

/// Reads a live ingest's counts from anywhere (a status route, a queryable).
#[derive(Debug, Clone)]
pub struct LiveWatch(Arc<Mutex<Option<Arc<LiveInput>>>>);

impl LiveWatch {
    /// The counts so far (all zero until the input is ready).
    pub fn stats(&self) -> LiveStats {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .as_ref()
            .map(|i| i.stats())
            .unwrap_or_default()
    }
}

impl LiveHandle {
    /// The counts so far (all zero until the input is ready).
    pub fn stats(&self) -> LiveStats {
        self.watch().stats()
    }

    /// A reader of the counts that outlives no one.
    pub fn watch(&self) -> LiveWatch {
        LiveWatch(self.input.clone())
    }

    /// Stops: what was received is mapped, committed and finished (post-processing and the
    /// hierarchy), then the thread ends. Returns its report.
    ///
    /// # Errors
    /// What opening the live build refused, or [`ToolError::Failed`] if the thread died.
    pub fn stop(mut self) -> ToolResult<BuildReport> {
        if let Some(s) = self.service.take() {
            s.set_live(None);
        }
        self.stop.store(true, Ordering::Relaxed);
        if let Some(i) = self
            .input
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .as_ref()
        {
            i.queue().close();
        }
        match self.thread.take().map(std::thread::JoinHandle::join) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(ToolError::Failed("the live mapping thread panicked".into())),
            None => Err(ToolError::Failed("live ingest already stopped".into())),
        }
    }

    /// Whether the mapping thread has ended (it ends early only on an error).
    pub fn is_finished(&self) -> bool {
        self.thread.as_ref().is_none_or(|t| t.is_finished())
    }
}

/// Starts live ingest into `service`'s store: opens (or continues) the live build, then
/// calls `on_ready` with the input side once, from the mapping thread, before the first
/// frame is awaited. Waits until the build is open, so a refusal is returned here.
///
/// # Errors
/// [`ToolError::Input`] for a bad configuration or a store that holds another build; the
/// embedder cannot be opened.
pub fn start(
    service: &Arc<Service>,
    req: LiveRequest,
    on_ready: Box<dyn FnOnce(Arc<LiveInput>) -> ToolResult<()> + Send>,
) -> ToolResult<LiveHandle> {
    req.live
        .validate()
        .and_then(|()| req.live.cam_from_velo().map(|_| ()))
        .map_err(|e| ToolError::Input(e.to_string()))?;
    let store = service.store().clone();
    let bus = service.clone();
    let stop = Arc::new(AtomicBool::new(false));
    let input: Arc<Mutex<Option<Arc<LiveInput>>>> = Arc::default();
    let (opened_tx, opened_rx) = std::sync::mpsc::channel::<ToolResult<()>>();
    let thread = {
        let stop = stop.clone();
        let slot = input.clone();
        std::thread::Builder::new()
            .name("opengraph-live".into())
            .spawn(move || -> ToolResult<BuildReport> {
                let mut emb = match req.embedder.open() {
                    Ok(e) => e,
                    Err(e) => {
                        let _ = opened_tx.send(Err(ToolError::Failed(e.to_string())));
                        return Err(e);
                    }
                };
                let mut merger = ingest::mapping::MedoidMerger;
                let mut on_ready = Some(on_ready);
                let mut ready_err = None;
                let mut ready = |i: Arc<LiveInput>| {
                    *slot.lock().unwrap_or_else(PoisonError::into_inner) = Some(i.clone());
                    let r = on_ready.take().map_or(Ok(()), |f| f(i));
                    if let Err(e) = &r {
                        ready_err = Some(e.to_string());
                        stop.store(true, Ordering::Relaxed);
                    }
                    let _ = opened_tx.send(r);
                };
                let mut emit = |e| {
                    bus.events().emit(e);
                };
                let out = ingest::build::run_live(
                    &store,
                    &req.build,
                    &req.live,
                    emb.as_mut(),
                    &mut merger,
                    &mut ready,
                    &mut emit,
                    &stop,
                );
                match out {
                    Ok(r) => match ready_err {
                        Some(e) => Err(ToolError::Failed(e)),
                        None => Ok(r),
                    },
                    Err(e) => {
                        let err = classify(&e);
                        let _ = opened_tx.send(Err(ToolError::Input(err.to_string())));
                        Err(err)
                    }
                }
            })
            .map_err(|e| ToolError::Failed(format!("cannot start the live thread: {e}")))?
    };
    let opened = opened_rx
        .recv()
        .unwrap_or_else(|_| Err(ToolError::Failed("the live thread ended at once".into())));
    let handle = LiveHandle {
        stop,
        input,
        thread: Some(thread),
        service: Some(service.clone()),
    };
    match opened {
        Ok(()) => {
            service.set_live(Some(handle.watch()));
            Ok(handle)
        }
        Err(e) => {
            let _ = handle.stop();
            Err(e)
        }
    }
}
