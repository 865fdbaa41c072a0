//! `opengraph._opengraph`: the native half of the `opengraph` Python package, a thin adapter
//! over the service layer (`opengraph-service`). Every operation takes and gives the same JSON
//! as the HTTP API (the request and answer types of `opengraph_service::ops` and friends); the
//! pure-Python half (`python/opengraph/__init__.py`) turns it into dicts, numpy arrays and
//! DataFrames. Calls release the GIL, so threads query one map at once (a pool of workers).
//! The service's one error kind becomes the exception hierarchy here, in one place
//! ([`py_err`]).

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use opengraph_service::builder::ServiceBuilder;
use opengraph_service::error::{ToolError, ToolResult};
use opengraph_service::find::{EmbedderChoice, Finder};
use opengraph_service::service::Service;
use opengraph_service::toolbox::Toolbox;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyTuple};

create_exception!(
    _opengraph,
    OpenGraphError,
    PyException,
    "Any OpenGraph failure; the message is the CLI's."
);
create_exception!(
    _opengraph,
    InputError,
    OpenGraphError,
    "What was given is unusable: bad arguments, bad Cypher, a missing or malformed file."
);
create_exception!(
    _opengraph,
    NotFoundError,
    OpenGraphError,
    "No node, edit or file by that id or name."
);
create_exception!(
    _opengraph,
    ConstraintError,
    OpenGraphError,
    "A write the map's schema or constraints refuse; nothing was changed."
);
create_exception!(
    _opengraph,
    ReadOnlyError,
    OpenGraphError,
    "A write on a map opened read-only (open it with read_only=False)."
);
create_exception!(
    _opengraph,
    TimeoutError,
    OpenGraphError,
    "The operation ran past its time limit."
);
create_exception!(
    _opengraph,
    BusyError,
    OpenGraphError,
    "No worker was free within the time limit."
);

/// The service's error as the Python exception of its kind.
fn py_err(e: ToolError) -> PyErr {
    let msg = e.to_string();
    match e {
        ToolError::Unknown(name) if opengraph_service::tools::is_write_tool(&name) => {
            ReadOnlyError::new_err(format!(
                "{name} changes the map, which is open read-only: opengraph.open(path, read_only=False)"
            ))
        }
        ToolError::Forbidden(_) => ReadOnlyError::new_err(msg),
        ToolError::Unknown(_) | ToolError::BadArguments(_) | ToolError::Input(_) => {
            InputError::new_err(msg)
        }
        ToolError::NotFound(_) => NotFoundError::new_err(msg),
        ToolError::Constraint(_) => ConstraintError::new_err(msg),
        ToolError::TimedOut(_) => TimeoutError::new_err(msg),
        ToolError::Busy(_) => BusyError::new_err(msg),
        _ => OpenGraphError::new_err(msg),
    }
}

fn json_arg(text: &str) -> PyResult<serde_json::Value> {
    serde_json::from_str(text).map_err(|e| InputError::new_err(format!("arguments: {e}")))
}

fn json_text(v: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(v).map_err(|e| OpenGraphError::new_err(e.to_string()))
}

/// An open map: the service over its store, with a runtime to run it on.
#[pyclass(module = "opengraph._opengraph", frozen)]
struct NativeMap {
    inner: Mutex<Option<(Arc<Service>, Arc<tokio::runtime::Runtime>)>>,
    path: PathBuf,
    read_only: bool,
}

impl NativeMap {
    fn service(&self) -> PyResult<(Arc<Service>, Arc<tokio::runtime::Runtime>)> {
        self.inner
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
            .ok_or_else(|| {
                OpenGraphError::new_err(format!("the map {} is closed", self.path.display()))
            })
    }
}

#[pymethods]
impl NativeMap {
    /// Calls the service operation `name` (a tool of the registry) with JSON arguments;
    /// returns the answer's JSON text.
    fn call(&self, py: Python<'_>, name: &str, args: &str) -> PyResult<String> {
        let (svc, rt) = self.service()?;
        let args = json_arg(args)?;
        let name = name.to_string();
        let out = py.detach(move || rt.block_on(svc.call(&name, args, true)));
        json_text(&out.map_err(py_err)?)
    }

    /// The map's summary (node and relationship counts) as JSON text.
    fn info(&self, py: Python<'_>) -> PyResult<String> {
        let (svc, rt) = self.service()?;
        let out = py.detach(move || rt.block_on(svc.info()));
        json_text(&out.map_err(py_err)?)
    }

    /// Exports the map as the JSON request `request` asks (an `ExportRequest`) to `path` (a
    /// file, or a folder for neo4j-csv); returns the `ExportAnswer` as JSON text.
    fn export(&self, py: Python<'_>, request: &str, path: PathBuf) -> PyResult<String> {
        let (svc, _) = self.service()?;
        let req: opengraph_service::export::ExportRequest =
            serde_json::from_str(request).map_err(|e| InputError::new_err(format!("{e}")))?;
        let out = py.detach(move || -> ToolResult<_> {
            use opengraph_service::export::{ExportTarget, export};
            let r = svc
                .store()
                .read()
                .map_err(|e| ToolError::Failed(e.to_string()))?;
            if req.format.is_folder() {
                export(&r, &req, ExportTarget::Folder(&path))
            } else {
                let f = std::fs::File::create(&path)
                    .map_err(|e| ToolError::Input(format!("creating {}: {e}", path.display())))?;
                let mut w = std::io::BufWriter::new(f);
                let a = export(&r, &req, ExportTarget::Writer(&mut w))?;
                use std::io::Write;
                w.flush()
                    .map_err(|e| ToolError::Failed(format!("writing {}: {e}", path.display())))?;
                Ok(a)
            }
        });
        json_text(&out.map_err(py_err)?)
    }

    /// The whole map as node-link JSON bytes (for networkx).
    fn node_link<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let (svc, rt) = self.service()?;
        let req = opengraph_service::export::ExportRequest::new(
            opengraph_service::export::ExportFormat::NodeLink,
        );
        let out = py.detach(move || rt.block_on(svc.export(req)));
        let (_, bytes, _) = out.map_err(py_err)?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// One instance's points: (count, little-endian float32 x y z bytes, world frame, metres).
    fn points<'py>(&self, py: Python<'py>, id: u64) -> PyResult<(usize, Bound<'py, PyBytes>)> {
        let (svc, rt) = self.service()?;
        let out = py.detach(move || rt.block_on(svc.points(id)));
        let (n, bytes) = out.map_err(py_err)?;
        Ok((n, PyBytes::new(py, &bytes)))
    }

    /// The tool registry (names, descriptions, schemas) as JSON text.
    fn tools(&self) -> PyResult<String> {
        let (svc, _) = self.service()?;
        json_text(&svc.tools())
    }

    /// Closes the map: later calls raise; the store closes when the last call using it ends.
    fn close(&self) {
        self.inner.lock().unwrap_or_else(|e| e.into_inner()).take();
    }

    /// Whether the map is closed.
    #[getter]
    fn closed(&self) -> bool {
        self.inner
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .is_none()
    }

    /// The store file.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// Whether the map was opened read-only.
    #[getter]
    fn read_only(&self) -> bool {
        self.read_only
    }
}

/// Opens the map at `path`: read-only (any number of readers) or for writing (one writer
/// process), with `workers` readers so that threads query at once.
#[pyfunction]
#[pyo3(signature = (path, read_only = true, embedder = None, workers = 2, timeout_secs = 30.0))]
fn open(
    py: Python<'_>,
    path: PathBuf,
    read_only: bool,
    embedder: Option<String>,
    workers: usize,
    timeout_secs: f64,
) -> PyResult<NativeMap> {
    let choice = match embedder.as_deref() {
        None => None,
        Some(n) => Some(EmbedderChoice::from_name(n).ok_or_else(|| {
            InputError::new_err(format!("embedder must be minilm or hash, not {n:?}"))
        })?),
    };
    if !(timeout_secs.is_finite() && timeout_secs > 0.0) {
        return Err(InputError::new_err(
            "timeout_secs must be a positive number",
        ));
    }
    let p = path.clone();
    let built = py.detach(move || -> ToolResult<Arc<Service>> {
        let opened = if read_only {
            graphstore::Store::open_read_only(&p)
        } else {
            graphstore::Store::open(&p)
        };
        let store = opened.map_err(|e| match e {
            graphstore::Error::Open { .. } | graphstore::Error::NotAStore { .. } => {
                ToolError::NotFound(e.to_string())
            }
            other => opengraph_service::error::classify(&other),
        })?;
        let finder = {
            let r = store.read().map_err(|e| ToolError::Failed(e.to_string()))?;
            Finder::for_map(&r, choice, None)?
        };
        let first = Toolbox::new(store, finder, !read_only);
        ServiceBuilder::new()
            .workers(workers.max(1))
            .writer(!read_only)
            .timeout(std::time::Duration::from_secs_f64(timeout_secs))
            .embedding_cache(256)
            .query_cache(64)
            .build(first, |s| {
                let r = s.read().map_err(|e| ToolError::Failed(e.to_string()))?;
                Finder::for_map(&r, choice, None)
            })
    });
    let service = built.map_err(py_err)?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .map_err(|e| OpenGraphError::new_err(format!("starting the runtime: {e}")))?;
    Ok(NativeMap {
        inner: Mutex::new(Some((service, Arc::new(rt)))),
        path,
        read_only,
    })
}

/// Makes a progress event's arguments while holding the GIL.
type MakeArgs<'a> = &'a dyn Fn(Python<'_>) -> PyResult<Bound<'_, PyTuple>>;

/// Runs a service operation that reports progress with the GIL released, calling `progress`
/// (a Python callable, or None) with each event's arguments; an exception raised by
/// `progress` is raised after the operation ends.
fn with_progress<T: Send>(
    py: Python<'_>,
    progress: Option<Py<PyAny>>,
    op: impl FnOnce(&(dyn Fn(MakeArgs<'_>) + Sync)) -> ToolResult<T> + Send,
) -> PyResult<T> {
    let failure: Mutex<Option<PyErr>> = Mutex::new(None);
    let emit = |make: MakeArgs<'_>| {
        let Some(cb) = &progress else { return };
        Python::attach(|py| {
            if let Err(e) = make(py).and_then(|args| cb.call1(py, args)) {
                let mut f = failure.lock().unwrap_or_else(|e| e.into_inner());
                if f.is_none() {
                    *f = Some(e);
                }
            }
        });
    };
    let out = py.detach(|| op(&emit));
    if let Some(e) = failure.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(e);
    }
    out.map_err(py_err)
}

/// Simulates a city (a `SimRequest` as JSON); `progress(done, total)` per sensor frame.
/// Returns the `SimReport` as JSON text.
#[pyfunction]
#[pyo3(signature = (request, progress = None))]
fn sim(py: Python<'_>, request: &str, progress: Option<Py<PyAny>>) -> PyResult<String> {
    let req: opengraph_service::sim::SimRequest =
        serde_json::from_str(request).map_err(|e| InputError::new_err(format!("{e}")))?;
    let report = with_progress(py, progress, |emit| {
        opengraph_service::sim::sim(&req, &|done, total| {
            emit(&|py| PyTuple::new(py, [done, total]))
        })
    })?;
    json_text(&report)
}

/// Builds a map (a `BuildRequest` as JSON); `progress(event, value)` per event: `("start",
/// (done, total))`, `("frame", n)`, `("committed", n)`, `("finishing", None)`. Returns the
/// `BuildAnswer` as JSON text.
#[pyfunction]
#[pyo3(signature = (request, progress = None))]
fn build(py: Python<'_>, request: &str, progress: Option<Py<PyAny>>) -> PyResult<String> {
    use opengraph_service::build::Progress;
    let req: opengraph_service::build::BuildRequest =
        serde_json::from_str(request).map_err(|e| InputError::new_err(format!("{e}")))?;
    let answer = with_progress(py, progress, |emit| {
        opengraph_service::build::build(&req, &mut |p| {
            emit(&|py| {
                let (name, value) = match p {
                    Progress::Start { done, total } => {
                        ("start", (done, total).into_pyobject(py)?.into_any())
                    }
                    Progress::Frame { frame } => ("frame", frame.into_pyobject(py)?.into_any()),
                    Progress::Committed { frame } => {
                        ("committed", frame.into_pyobject(py)?.into_any())
                    }
                    Progress::Finishing => ("finishing", py.None().into_bound(py)),
                };
                PyTuple::new(py, [name.into_pyobject(py)?.into_any(), value])
            })
        })
    })?;
    json_text(&answer)
}

/// The JSON Schema of every typed operation's request, by name, as JSON text.
#[pyfunction]
fn schemas() -> PyResult<String> {
    use opengraph_service::ops::schema_of;
    let v = serde_json::json!({
        "build": schema_of::<opengraph_service::build::BuildRequest>(),
        "sim": schema_of::<opengraph_service::sim::SimRequest>(),
        "export": schema_of::<opengraph_service::export::ExportRequest>(),
    });
    json_text(&v)
}

#[pymodule]
fn _opengraph(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<NativeMap>()?;
    m.add_function(wrap_pyfunction!(open, m)?)?;
    m.add_function(wrap_pyfunction!(sim, m)?)?;
    m.add_function(wrap_pyfunction!(build, m)?)?;
    m.add_function(wrap_pyfunction!(schemas, m)?)?;
    m.add("OpenGraphError", py.get_type::<OpenGraphError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("NotFoundError", py.get_type::<NotFoundError>())?;
    m.add("ConstraintError", py.get_type::<ConstraintError>())?;
    m.add("ReadOnlyError", py.get_type::<ReadOnlyError>())?;
    m.add("TimeoutError", py.get_type::<TimeoutError>())?;
    m.add("BusyError", py.get_type::<BusyError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
