#![doc = include_str!("../README.md")]

pub mod chat;
pub mod edit;
pub mod embed;
pub mod embed_cache;
mod error;
pub mod graph_find;
pub mod hash_embed;
pub mod kinds;
pub mod labels;
pub mod locate;
pub mod prompts;
pub mod request;
pub mod retrieve;
pub mod vocab;
pub mod wordpiece;

pub use chat::{
    ChatModel, ChatRequest, ChatResponse, LlmConfig, Message, Role, ToolCall, ToolSpec,
};
pub use embed::{Embedder, MiniLm};
pub use embed_cache::{CachedEmbedder, EmbeddingCache};
pub use error::{Error, Result};
pub use hash_embed::HashEmbedder;
