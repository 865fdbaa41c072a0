#![doc = include_str!("../README.md")]

use std::path::PathBuf;

pub mod keys;
pub mod replay;
pub mod subscribe;

/// Everything that can go wrong on the zenoh side.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The zenoh configuration is unusable (a bad file, endpoint or key).
    #[error("zenoh configuration: {0}")]
    Config(String),
    /// zenoh failed (opening the session, declaring, publishing).
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// Reading the sequence or converting its data failed.
    #[error(transparent)]
    Ingest(#[from] ingest::Error),
    /// A file could not be read.
    #[error("{}: {detail}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
}

/// Result alias for og-zenoh.
pub type Result<T, E = Error> = std::result::Result<T, E>;

fn zerr(e: impl std::fmt::Display) -> Error {
    Error::Zenoh(e.to_string())
}

/// How to open a zenoh session. With a configuration file, the file is used as it is;
/// otherwise a peer with multicast scouting off that listens on `listen` (default
/// `tcp/127.0.0.1:7447`, loopback only, unless `connect` is given) and connects to
/// `connect`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SessionOptions {
    /// A zenoh JSON5 configuration file.
    pub config_file: Option<PathBuf>,
    /// Endpoints to listen on, e.g. `tcp/127.0.0.1:7447`.
    pub listen: Vec<String>,
    /// Endpoints to connect to (a router, or another peer).
    pub connect: Vec<String>,
}

/// The default listening endpoint: zenoh's port, on loopback only.
pub const DEFAULT_LISTEN: &str = "tcp/127.0.0.1:7447";

impl SessionOptions {
    /// A peer that listens on `listen` and connects to `connect`, scouting off: what tests
    /// on loopback use.
    pub fn peer(listen: &[String], connect: &[String]) -> SessionOptions {
        SessionOptions {
            config_file: None,
            listen: listen.to_vec(),
            connect: connect.to_vec(),
        }
    }

    /// The zenoh configuration.
    ///
    /// # Errors
    /// [`Error::Config`] for an unreadable or invalid file, or an endpoint zenoh refuses.
    pub fn config(&self) -> Result<zenoh::Config> {
        if let Some(f) = &self.config_file {
            if !self.listen.is_empty() || !self.connect.is_empty() {
                return Err(Error::Config(
                    "give either a configuration file or listen/connect endpoints, not both".into(),
                ));
            }
            return zenoh::Config::from_file(f)
                .map_err(|e| Error::Config(format!("{}: {e}", f.display())));
        }
        let mut c = zenoh::Config::default();
        let set = |c: &mut zenoh::Config, k: &str, v: String| {
            c.insert_json5(k, &v)
                .map_err(|e| Error::Config(format!("{k} = {v}: {e}")))
        };
        set(&mut c, "mode", "\"peer\"".into())?;
        set(&mut c, "scouting/multicast/enabled", "false".into())?;
        let listen: Vec<String> = if self.listen.is_empty() && self.connect.is_empty() {
            vec![DEFAULT_LISTEN.into()]
        } else {
            self.listen.clone()
        };
        let list = |v: &[String]| serde_json::to_string(v).expect("strings");
        set(&mut c, "listen/endpoints", list(&listen))?;
        set(&mut c, "connect/endpoints", list(&self.connect))?;
        Ok(c)
    }

    /// Opens the session (blocking).
    ///
    /// # Errors
    /// [`Error::Config`], or [`Error::Zenoh`] when zenoh cannot open it (a port in use, say).
    pub fn open(&self) -> Result<zenoh::Session> {
        use zenoh::Wait;
        let c = self.config()?;
        zenoh::open(c).wait().map_err(|e| {
            Error::Zenoh(format!(
                "cannot open a session (listen {:?}, connect {:?}): {e}",
                self.listen, self.connect
            ))
        })
    }
}
