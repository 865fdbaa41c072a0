//! The `find` and `locate` operations, transport-free. `find`: plain embedding ranking, or
//! graph-aware retrieval over a parsed request (rule or LLM parser), optionally re-ranked by a
//! language model (OpenGraph-LLM). `locate`: road segments ranked for a description of the
//! surroundings, with a position estimate. The CLI's `find`, `locate` and `eval` call them; the
//! server will too.

use std::sync::Arc;
use std::time::Instant;

use graphstore::GraphRead;
use llm_tools::graph_find::{self, GraphFindOptions, GraphFound, MapView};
use llm_tools::locate::{self, Description, Located};
use llm_tools::request::{self, Request};
use llm_tools::retrieve::{self, FindOptions};
use llm_tools::{ChatModel, Embedder, Result};

/// Longest request text, in characters (the agent tools' schemas say the same).
pub const MAX_TEXT_CHARS: usize = 2000;

fn check_text(text: &str, what: &str) -> Result<()> {
    if text.trim().is_empty() {
        return Err(llm_tools::Error::Invalid(format!(
            "the {what} text is empty"
        )));
    }
    let n = text.chars().count();
    if n > MAX_TEXT_CHARS {
        return Err(llm_tools::Error::Invalid(format!(
            "the {what} text has {n} characters; at most {MAX_TEXT_CHARS} are taken"
        )));
    }
    Ok(())
}

/// How a request becomes a structured request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParserKind {
    /// The deterministic rule parser.
    Rules,
    /// The language model under the request schema.
    Llm,
}

/// How results are ranked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ranking {
    /// Cosine of the whole text with each instance's feature (no parsing, no graph).
    Plain,
    /// Graph-aware: target and anchors, relations, segments.
    Graph {
        /// Which parser.
        parser: ParserKind,
        /// Let the language model pick the best three of the first `rerank_n`.
        rerank: bool,
    },
}

/// A find request.
#[derive(Debug, Clone, PartialEq)]
pub struct FindRequest {
    /// The text.
    pub text: String,
    /// How many results.
    pub k: usize,
    /// Only this class.
    pub class: Option<String>,
    /// Only within `radius_m` of a ground point.
    pub near: Option<([f64; 2], f64)>,
    /// How to rank.
    pub ranking: Ranking,
    /// Candidates shown to the re-ranking model.
    pub rerank_n: usize,
}

/// A find answer.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct FindAnswer {
    /// The structured request (graph-aware ranking only).
    pub request: Option<Request>,
    /// The model that parsed it (`--parser llm`) with the prompt id.
    pub parsed_by: Option<String>,
    /// The model that re-ranked (`--rerank llm`) with the prompt id.
    pub reranked_by: Option<String>,
    /// Results, best first.
    pub results: Vec<GraphFound>,
    /// Milliseconds: parse, rank (embedding included), re-rank.
    pub timings_ms: [f64; 3],
}

/// Which sentence embedder makes the captions' features.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum EmbedderChoice {
    /// all-MiniLM-L6-v2 (the real model; `scripts/setup.sh` fetches it).
    #[default]
    Minilm,
    /// A deterministic bag of words, for tests: it captures no meaning.
    Hash,
}

impl EmbedderChoice {
    /// The embedder.
    ///
    /// # Errors
    /// [`ToolError::Input`] when the model files are missing or unreadable.
    pub fn open(self) -> crate::error::ToolResult<Box<dyn llm_tools::Embedder + Send>> {
        Ok(match self {
            EmbedderChoice::Hash => Box::new(llm_tools::HashEmbedder::new(scene::FEATURE_DIM)),
            EmbedderChoice::Minilm => Box::new(
                llm_tools::MiniLm::from_dir(&llm_tools::embed::default_models_dir()).map_err(
                    |e| {
                        crate::error::ToolError::Input(format!(
                            "loading the sentence embedder: {e}"
                        ))
                    },
                )?,
            ),
        })
    }
}

impl EmbedderChoice {
    /// The embedder named `name` (`minilm` or `hash`).
    pub fn from_name(name: &str) -> Option<EmbedderChoice> {
        match name {
            "minilm" => Some(EmbedderChoice::Minilm),
            "hash" => Some(EmbedderChoice::Hash),
            _ => None,
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            EmbedderChoice::Minilm => "minilm",
            EmbedderChoice::Hash => "hash",
        }
    }
}

/// Holds what many find requests share: the embedder, the loaded scene, a language model.
pub struct Finder {
    embedder: Box<dyn Embedder + Send>,
    llm: Option<Box<dyn ChatModel>>,
    /// The loaded scene and the commit it was loaded at.
    scene: Option<(u64, Arc<MapView>)>,
    /// A scene shared with other finders (a server's workers), loaded once per commit.
    shared_scene: Option<Arc<SharedScene>>,
}

/// The scene of the latest commit, shared by finders (a server's workers): after a write
/// the first request loads it, one that asks meanwhile waits for that load, and the others
/// take it. Make it with `SharedScene::new(1)`.
pub type SharedScene = crate::commit_cache::CommitCache<(), MapView>;

/// How long a finder waits for another's load of the same scene before loading it itself.
const SCENE_WAIT: std::time::Duration = std::time::Duration::from_secs(30);

/// A locate request.
#[derive(Debug, Clone, PartialEq)]
pub struct LocateRequest {
    /// The description of the surroundings.
    pub text: String,
    /// How many segments.
    pub k: usize,
    /// Who parses it.
    pub parser: ParserKind,
}

/// A locate answer.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct LocateAnswer {
    /// What the description says.
    pub description: Description,
    /// The model that parsed it, with the prompt id.
    pub parsed_by: Option<String>,
    /// Segments, best first (none when nothing said is in the map and no kind was said).
    pub results: Vec<Located>,
    /// Landmarks nothing in the map matches well (best cosine under the weak-match level);
    /// they were left out.
    pub unmatched: Vec<locate::UnmatchedLandmark>,
    /// Milliseconds: parse, rank.
    pub timings_ms: [f64; 2],
}

impl std::fmt::Debug for Finder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Finder")
            .field("embedder", &self.embedder.name())
            .field("llm", &self.llm.as_ref().map(|m| m.model_id()))
            .field("scene_loaded", &self.scene.is_some())
            .field("scene_shared", &self.shared_scene.is_some())
            .finish()
    }
}

impl Finder {
    /// A finder with this embedder and, for the LLM parser or re-ranking, a model.
    pub fn new(embedder: Box<dyn Embedder + Send>, llm: Option<Box<dyn ChatModel>>) -> Finder {
        Finder {
            embedder,
            llm,
            scene: None,
            shared_scene: None,
        }
    }

    /// A finder for the map read through `r`: with the embedder its features were made with
    /// (its `Build` node says; `minilm` when none does), or `embedder` when given and the
    /// same.
    ///
    /// # Errors
    /// [`crate::error::ToolError::Input`] when `embedder` differs from the map's, or the
    /// embedder cannot be loaded; the store fails.
    pub fn for_map(
        r: &impl GraphRead,
        embedder: Option<EmbedderChoice>,
        llm: Option<Box<dyn ChatModel>>,
    ) -> crate::error::ToolResult<Finder> {
        use crate::error::ToolError;
        let built = llm_tools::retrieve::map_embedder(r)?;
        let choice = match (embedder, built) {
            (Some(e), Some(b)) if e.name() != b => {
                return Err(ToolError::Input(format!(
                    "the map was built with the {b} embedder; query it with the same one (--embedder {b})"
                )));
            }
            (Some(e), _) => e,
            (None, b) => match b.as_deref() {
                None => EmbedderChoice::Minilm,
                Some(name) => EmbedderChoice::from_name(name).ok_or_else(|| {
                    ToolError::Input(format!(
                        "the map was built with an unknown embedder {name:?}"
                    ))
                })?,
            },
        };
        Ok(Finder::new(choice.open()?, llm))
    }

    fn llm(&mut self) -> Result<&mut Box<dyn ChatModel>> {
        self.llm.as_mut().ok_or_else(|| {
            llm_tools::Error::Invalid(
                "this needs a language model: pass --llm local (or openai with --llm-url)".into(),
            )
        })
    }

    /// The map's scene (instances and segments) as of `r`'s commit: kept while the commit
    /// is the same, taken from the shared slot when another finder loaded it, else made: from
    /// the newest earlier scene at hand (this finder's or the shared slot's) and the nodes
    /// changed since ([`MapView::refresh`]) when the store still lists them, else loaded
    /// whole. Inside a write transaction it is loaded every time and not kept.
    ///
    /// # Errors
    /// The store fails or has no ground frame.
    pub fn scene(&mut self, r: &impl GraphRead) -> Result<Arc<MapView>> {
        let Some(seq) = r.commit_seq() else {
            return Ok(Arc::new(MapView::load(r)?));
        };
        if let Some((s, scene)) = &self.scene
            && *s == seq
        {
            return Ok(scene.clone());
        }
        let earlier = self
            .scene
            .clone()
            .into_iter()
            .chain(self.shared_scene.as_ref().and_then(|sh| sh.latest(&())))
            .filter(|(s, _)| *s < seq)
            .max_by_key(|(s, _)| *s);
        let make = || -> Result<MapView> {
            if let Some((s, prev)) = &earlier
                && let Some(changed) = r.nodes_changed_since(*s)
            {
                return Ok(prev.refresh(r, &changed)?);
            }
            Ok(MapView::load(r)?)
        };
        let scene = match &self.shared_scene {
            Some(sh) => sh.get_or_compute((), seq, SCENE_WAIT, || {
                Ok::<_, llm_tools::Error>((make()?, true))
            })?,
            None => Arc::new(make()?),
        };
        self.scene = Some((seq, scene.clone()));
        Ok(scene)
    }

    /// Keeps `scene`, loaded from `r`, as this finder's scene for `r`'s commit (a one-shot
    /// command loads it beside the embedder). Inside a write transaction it is not kept.
    pub fn keep_scene(&mut self, r: &impl GraphRead, scene: Arc<MapView>) {
        if let Some(seq) = r.commit_seq() {
            self.scene = Some((seq, scene));
        }
    }

    /// Shares loaded scenes with every other finder given `shared` (a server's workers):
    /// one load per commit instead of one per worker.
    pub fn share_scene(&mut self, shared: Arc<SharedScene>) {
        self.shared_scene = Some(shared);
    }

    /// The cosine below which a best match is no match (the map holds nothing like the
    /// request): measured on the default small city, MiniLM gives 0.21–0.34 for nonsense
    /// ("xyzzy qwerty", "a purple elephant", "a dead end") and 0.50–0.81 for things the map
    /// holds. The hash embedder (for tests) has no such level: nonsense sharing "the" scores
    /// 0.26 and a real request 0.21, so it gets 0 (no guard).
    pub fn weak_match_cosine(&self) -> f64 {
        if self.embedder.name() == "hash" {
            0.0
        } else {
            0.4
        }
    }

    /// The language model (for parsers outside `find`, such as map updates).
    ///
    /// # Errors
    /// The finder was made without one.
    pub fn chat_model(&mut self) -> Result<&mut dyn ChatModel> {
        Ok(self.llm()?.as_mut())
    }

    /// Looks query embeddings up in `cache` first, sharing it with every other finder given
    /// it; the answers stay the embedder's own.
    pub fn share_embedding_cache(&mut self, cache: std::sync::Arc<llm_tools::EmbeddingCache>) {
        let inner = std::mem::replace(
            &mut self.embedder,
            Box::new(llm_tools::HashEmbedder::new(1)),
        );
        self.embedder = Box::new(llm_tools::CachedEmbedder::new(inner, cache));
    }

    /// Sentence embeddings of `texts` with the map's embedder.
    ///
    /// # Errors
    /// The embedder fails.
    pub fn embed(&mut self, texts: &[&str]) -> Result<Vec<Vec<f32>>> {
        self.embedder.embed(texts)
    }

    /// Ranks the map's segments for a description of the surroundings.
    ///
    /// # Errors
    /// Empty text, a map built with another embedder, no ground frame, a failing model.
    pub fn locate(&mut self, r: &impl GraphRead, req: &LocateRequest) -> Result<LocateAnswer> {
        Ok(self
            .locate_normed(r, req, &locate::LocateNorms::default())?
            .0)
    }

    /// [`Finder::locate`] over one part of a map (a region shard) under the whole map's
    /// `norms` ([`locate::LocateNorms`]); also this part's [`locate::LocateStats`].
    ///
    /// # Errors
    /// As [`Finder::locate`].
    pub fn locate_normed(
        &mut self,
        r: &impl GraphRead,
        req: &LocateRequest,
        norms: &locate::LocateNorms,
    ) -> Result<(LocateAnswer, locate::LocateStats)> {
        check_text(&req.text, "description")?;
        self.check_embedder(r)?;
        let t0 = Instant::now();
        let (description, parsed_by) = match req.parser {
            ParserKind::Rules => (locate::parse_description_rules(&req.text)?, None),
            ParserKind::Llm => {
                if req.text.trim().is_empty() {
                    return Err(llm_tools::Error::Invalid("the description is empty".into()));
                }
                let m = self.llm()?;
                let d = locate::parse_description_llm(m.as_mut(), &req.text)?;
                let id = format!(
                    "{} ({})",
                    m.model_id(),
                    llm_tools::prompts::PARSE_REQUEST.id()
                );
                (d, Some(id))
            }
        };
        let parse_ms = t0.elapsed().as_secs_f64() * 1e3;
        let t1 = Instant::now();
        let scene = self.scene(r)?;
        let scene = &*scene;
        // the hash embedder has no weak-match level (0): no floor then
        let floor = Some(self.weak_match_cosine())
            .filter(|w| *w > 0.0)
            .unwrap_or(f64::NEG_INFINITY);
        let (results, unmatched, stats) = locate::locate_normed(
            scene,
            &scene.segments,
            self.embedder.as_mut(),
            &description,
            req.k,
            floor,
            norms,
        )?;
        Ok((
            LocateAnswer {
                description,
                parsed_by,
                results,
                unmatched,
                timings_ms: [parse_ms, t1.elapsed().as_secs_f64() * 1e3],
            },
            stats,
        ))
    }

    fn check_embedder(&self, r: &impl GraphRead) -> Result<()> {
        if let Some(built) = retrieve::map_embedder(r)?
            && built != self.embedder.name()
        {
            return Err(llm_tools::Error::Invalid(format!(
                "the map was built with the {built} embedder; query it with the same one (--embedder {built})"
            )));
        }
        Ok(())
    }

    /// Answers one request over the map `r` (the scene is loaded on first use).
    ///
    /// # Errors
    /// Empty text, a map built with another embedder, a store without a ground frame
    /// (graph-aware ranking), or a language model that fails.
    pub fn find(&mut self, r: &impl GraphRead, req: &FindRequest) -> Result<FindAnswer> {
        Ok(self.find_normed(r, req, None)?.0)
    }

    /// [`Finder::find`] over one part of a map (a region shard): graph-aware ranking under
    /// the whole map's `norms` ([`graph_find::FindNorms`]); also this part's
    /// [`graph_find::FindCuts`] (empty for plain ranking, which needs no norms: its scores
    /// are cosines).
    ///
    /// # Errors
    /// As [`Finder::find`].
    pub fn find_normed(
        &mut self,
        r: &impl GraphRead,
        req: &FindRequest,
        norms: Option<&graph_find::FindNorms>,
    ) -> Result<(FindAnswer, graph_find::FindCuts)> {
        self.check_request(r, req)?;
        let (parser, rerank) = match req.ranking {
            Ranking::Plain => {
                let opts = FindOptions {
                    k: req.k,
                    class: req.class.clone(),
                    near: req.near,
                };
                let (hits, t) = retrieve::find(r, self.embedder.as_mut(), &req.text, &opts)?;
                let results = hits
                    .into_iter()
                    .map(|h| GraphFound {
                        id: h.id,
                        label: h.label,
                        caption: h.caption,
                        semantic_class: h.semantic_class,
                        score: h.score,
                        similarity: h.score,
                        cosine: h.score,
                        centroid: h.centroid,
                        segment: None,
                        segment_match: None,
                        evidence: Vec::new(),
                        place_distance_m: None,
                    })
                    .collect();
                return Ok((
                    FindAnswer {
                        request: None,
                        parsed_by: None,
                        reranked_by: None,
                        results,
                        timings_ms: [0.0, t.embed_ms + t.rank_ms, 0.0],
                    },
                    graph_find::FindCuts::default(),
                ));
            }
            Ranking::Graph { parser, rerank } => (parser, rerank),
        };
        let t0 = Instant::now();
        let (parsed, parsed_by) = self.parse_request(&req.text, parser)?;
        let parse_ms = t0.elapsed().as_secs_f64() * 1e3;
        self.find_parsed(r, req, rerank, parsed, parsed_by, parse_ms, norms)
    }

    /// Checks a request before any work: its text, its class, and that the map was built
    /// with this finder's embedder.
    ///
    /// # Errors
    /// Empty or overlong text, a class that is not one of the 19, a map built with another
    /// embedder.
    pub fn check_request(&self, r: &impl GraphRead, req: &FindRequest) -> Result<()> {
        check_text(&req.text, "query")?;
        if let Some(c) = &req.class
            && !scene::classes::CLASSES.contains(&c.as_str())
        {
            return Err(llm_tools::Error::Invalid(format!(
                "class {c:?} is not one of the 19 SemanticKITTI classes a map's instances carry: {}",
                scene::classes::CLASSES.join(", ")
            )));
        }
        self.check_embedder(r)
    }

    /// A request in words as one structured [`Request`], by the rules or the language model
    /// (then with the model and prompt id).
    ///
    /// # Errors
    /// The text names nothing; the model fails.
    pub fn parse_request(
        &mut self,
        text: &str,
        parser: ParserKind,
    ) -> Result<(Request, Option<String>)> {
        Ok(match parser {
            ParserKind::Rules => (request::parse_rules(text)?, None),
            ParserKind::Llm => {
                let m = self.llm()?;
                let p = request::parse_llm(m.as_mut(), text)?;
                (
                    p,
                    Some(format!(
                        "{} ({})",
                        m.model_id(),
                        llm_tools::prompts::PARSE_REQUEST.id()
                    )),
                )
            }
        })
    }

    /// Graph-aware ranking of an already parsed request (see [`Finder::find_normed`]).
    ///
    /// # Errors
    /// As [`Finder::find`].
    #[allow(clippy::too_many_arguments)]
    pub fn find_parsed(
        &mut self,
        r: &impl GraphRead,
        req: &FindRequest,
        rerank: bool,
        parsed: Request,
        parsed_by: Option<String>,
        parse_ms: f64,
        norms: Option<&graph_find::FindNorms>,
    ) -> Result<(FindAnswer, graph_find::FindCuts)> {
        let t1 = Instant::now();
        let scene = self.scene(r)?;
        let scene = &*scene;
        let opts = GraphFindOptions {
            k: if rerank {
                req.k.max(req.rerank_n)
            } else {
                req.k
            },
            class: req.class.clone(),
            near: req.near,
            ..GraphFindOptions::default()
        };
        let (mut results, cuts) =
            graph_find::find_graph_normed(r, scene, self.embedder.as_mut(), &parsed, &opts, norms)?;
        let rank_ms = t1.elapsed().as_secs_f64() * 1e3;
        let t2 = Instant::now();
        let mut reranked_by = None;
        if rerank {
            let n = req.rerank_n;
            let m = self.llm()?;
            let (r2, model) = graph_find::rerank_llm(m.as_mut(), &req.text, results, n)?;
            results = r2;
            reranked_by = Some(format!("{model} ({})", llm_tools::prompts::RERANK.id()));
        }
        results.truncate(req.k);
        Ok((
            FindAnswer {
                request: Some(parsed),
                parsed_by,
                reranked_by,
                results,
                timings_ms: [parse_ms, rank_ms, t2.elapsed().as_secs_f64() * 1e3],
            },
            cuts,
        ))
    }
}
