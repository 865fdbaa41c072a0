//! The `opengraph` command-line tool.

/// `println!` that returns an error instead of panicking when stdout is closed (`| head`);
/// `main` turns that error into a quiet exit.
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($t)*)?
    }};
}

/// `print!` with the same closed-pipe handling as [`outln!`].
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout(), $($t)*)?
    }};
}

/// `eprintln!` that never panics: a log line is dropped when stderr is gone, so a build never
/// stops because its log reader left.
macro_rules! errln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};

use api::{demo, info};

/// OpenGraph: an open-vocabulary hierarchical 3D scene graph for outdoor environments.
#[derive(Debug, Parser)]
#[command(name = "opengraph", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Print node counts per label and relationship counts per type.
    Info {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// Print `{"nodes": {LABEL: n}, "relationships": {TYPE: n}}` instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Export the whole graph (payloads such as point clouds are left out).
    Export {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// node-link (networkx JSON) or graphml.
        #[arg(long, value_parser = ["node-link", "graphml"])]
        format: String,
        /// Output file.
        #[arg(long)]
        out: PathBuf,
        /// node-link only: key of the edge list; `links` for networkx older than 3.6.
        #[arg(long, default_value = "edges", value_parser = ["edges", "links"])]
        edges_key: String,
    },
    /// Extract the lane graph and road segments from a KITTI-format trajectory.
    Lanes {
        /// poses.txt (3x4 world-from-cam0 per line).
        #[arg(long)]
        poses: PathBuf,
        /// calib.txt: use the velodyne position (pose x Tr) instead of the camera's.
        #[arg(long)]
        calib: Option<PathBuf>,
        /// Use every N-th pose.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
        stride: u32,
        /// GeoJSON output (ground-plane metres: KITTI x and z).
        #[arg(long)]
        out: PathBuf,
        /// Bird's-eye PNG: trajectory, lane edges, nodes coloured by kind, segment areas.
        #[arg(long)]
        png: Option<PathBuf>,
        /// Print `{"nodes": [{"id", "kind", "xy"}], "edges": [{"from", "to", "length_m"}]}`.
        #[arg(long)]
        json: bool,
    },
    /// Write the hierarchy (environment, segments, lane graph) into a store from a KITTI-format
    /// trajectory, and link the store's instances (IN_SEGMENT, geometric RELATED). Replaces a
    /// previous hierarchy in that store.
    Hierarchy {
        /// The store file (created if missing).
        #[arg(long)]
        db: PathBuf,
        /// poses.txt (3x4 world-from-cam0 per line).
        #[arg(long)]
        poses: PathBuf,
        /// calib.txt: use the velodyne position (pose x Tr) instead of the camera's.
        #[arg(long)]
        calib: Option<PathBuf>,
        /// Name of the environment node.
        #[arg(long, default_value = "environment")]
        name: String,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Route over the store's lane graph (A*) and refine it into a drivable path with OMPL.
    Plan {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// Start: X,Y (ground plane), or lane:ID, segment:ID, instance:ID, node:ID with a node id
        /// (the id `find`, `query` and exports print).
        #[arg(long, allow_hyphen_values = true)]
        from: String,
        /// Goal, in the same forms.
        #[arg(long, allow_hyphen_values = true)]
        to: String,
        #[command(flatten)]
        opts: PlanArgs,
        /// Print `{"route": {...}, "path": {...}}` as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Plan a route described in words: "from the bus stop by the crossroads to somewhere I
    /// can post a letter". Each end is found (graph-aware `find`) or located (`locate`, for a
    /// road place or a description), or given as a spec with --from / --to; then `plan`.
    Navigate {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// The request ("from A to B", "take me to B" with --from).
        text: Option<String>,
        /// The start, in words or as a spec (X,Y, lane:ID, segment:ID, instance:ID, node:ID);
        /// overrides the text's.
        #[arg(long, allow_hyphen_values = true)]
        from: Option<String>,
        /// The goal, in words or as a spec; overrides the text's.
        #[arg(long, allow_hyphen_values = true)]
        to: Option<String>,
        /// Who parses the ends: the rule parser or the language model.
        #[arg(long, value_parser = ["rules", "llm"], default_value = "rules")]
        parser: String,
        #[command(flatten)]
        llm: LlmArgs,
        #[command(flatten)]
        opts: PlanArgs,
        /// Print {"start", "goal", "plan"} as JSON: each end with how it was resolved and its
        /// evidence, the route and the path.
        #[arg(long)]
        json: bool,
    },
    /// Build an object map from a KITTI-layout sequence and per-frame detections (or the
    /// SemanticKITTI label oracle), then the hierarchy over the whole trajectory.
    Build {
        /// The sequence directory (velodyne/, calib.txt, poses.txt; labels/ for the oracle).
        #[arg(long)]
        kitti: PathBuf,
        /// A directory of detections files NNNNNN.json (docs/detections.md).
        #[arg(
            long,
            conflicts_with = "oracle_labels",
            required_unless_present = "oracle_labels"
        )]
        detections: Option<PathBuf>,
        /// Use the SemanticKITTI label oracle instead of detections.
        #[arg(long)]
        oracle_labels: bool,
        /// Key frames A..B (half-open); default: every frame with a scan and detections/labels.
        #[arg(long, value_parser = parse_range)]
        frames: Option<std::ops::Range<u32>>,
        /// Use every N-th frame.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
        stride: u32,
        /// Scans accumulated into each key frame (overrides the config's mapping.accumulate).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        accumulate: Option<u32>,
        /// poses.txt from another path.
        #[arg(long)]
        poses: Option<PathBuf>,
        /// TOML file with [mapping], [oracle] and [hierarchy] tables (docs/config.md).
        #[arg(long)]
        config: Option<PathBuf>,
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// Continue a build that was interrupted (same arguments).
        #[arg(long)]
        resume: bool,
        /// Name of the environment node.
        #[arg(long, default_value = "environment")]
        name: String,
        /// Sentence embedder: minilm (the real model), or hash (deterministic bag of words,
        /// for tests; captures no meaning).
        #[arg(long, default_value = "minilm", value_parser = ["minilm", "hash"])]
        embedder: String,
        /// The language model that merges each object's captions after mapping (overrides the
        /// config's [llm] table; default none: the medoid caption).
        #[command(flatten)]
        llm: LlmArgs,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Write the label oracle's detections for a sequence as detections files.
    Oracle {
        /// The sequence directory (velodyne/, labels/, calib.txt, poses.txt).
        #[arg(long)]
        kitti: PathBuf,
        /// Output directory for NNNNNN.json.
        #[arg(long)]
        out: PathBuf,
        /// Frames A..B (half-open); default: every labelled frame.
        #[arg(long, value_parser = parse_range)]
        frames: Option<std::ops::Range<u32>>,
    },
    /// Generate a synthetic city and a drive through it: a KITTI-layout sequence (calib,
    /// 10 Hz poses, LiDAR scans with SemanticKITTI labels), detections files, and ground
    /// truth (objects, roads, what produced each detection). Byte-identical for a seed.
    Sim {
        /// Output directory (must not already hold a sequence).
        #[arg(long)]
        out: PathBuf,
        /// Seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// small (~1 km of road), medium (~5 km) or city (>= 20 km, >= 20,000 objects).
        #[arg(long, default_value = "small", value_parser = ["small", "medium", "city"])]
        size: String,
        /// Sensor frames (scan + labels + detections), spread evenly over the drive.
        /// Default: 300 small, 600 medium, 1000 city.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        frames: Option<u32>,
        /// Probability that a visible object is not detected.
        #[arg(long, default_value_t = 0.05)]
        miss_rate: f64,
        /// Mean false-positive detections per frame.
        #[arg(long, default_value_t = 0.2)]
        false_positives: f64,
        /// Probability of a caption phrased differently from the ground truth.
        #[arg(long, default_value_t = 0.5)]
        paraphrase_rate: f64,
        /// Probability of a caption with a wrong colour.
        #[arg(long, default_value_t = 0.05)]
        wrong_attribute_rate: f64,
        /// Masks are eroded or dilated by up to this many pixels.
        #[arg(long, default_value_t = 1)]
        mask_noise_px: u32,
        /// No detection noise at all (overrides the five options above).
        #[arg(long)]
        no_noise: bool,
        /// Worker threads (the output does not depend on it); default: all cores.
        #[arg(long)]
        threads: Option<usize>,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Label relations between close objects with a language model (the paper's LLM relation
    /// inference): RELATED {source: "llm", relation, confidence, model, prompt} beside the
    /// geometric edges. Resumable: pairs already labelled by the same model and prompt are
    /// skipped, and every answer is cached in the map.
    Relations {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        #[command(flatten)]
        llm: LlmArgs,
        /// Stop starting new pairs after this many seconds (run again to continue).
        #[arg(long, value_parser = parse_budget, allow_hyphen_values = true)]
        budget_secs: Option<f64>,
        /// Label at most this many pairs in this run.
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        max_pairs: Option<u64>,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Merge each object's captions into one with a language model (the paper's LLM caption
    /// merge); `build --llm` runs the same pass after mapping. Resumable and cached.
    Captions {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        #[command(flatten)]
        llm: LlmArgs,
        /// How many of an object's latest captions are merged.
        #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u64).range(2..=16))]
        recent: u64,
        /// Stop starting new merges after this many seconds (run again to continue).
        #[arg(long, value_parser = parse_budget, allow_hyphen_values = true)]
        budget_secs: Option<f64>,
        /// Merge at most this many objects in this run.
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        max_items: Option<u64>,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Open-vocabulary retrieval over the map's hierarchy: the request is parsed into a
    /// target, anchors with relations and a segment constraint ("the bench near the bus stop
    /// at the T-junction", "somewhere I can post a letter"), and instances are scored by
    /// similarity, relation fit to the anchors, RELATED edges and IN_SEGMENT. Ground surfaces
    /// are answers only when asked for. `--plain` ranks by the cosine of the whole text alone.
    Find {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// What to look for, in words.
        text: String,
        /// How many results.
        #[arg(short, long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=1000))]
        k: u64,
        /// Only this class.
        #[arg(long)]
        class: Option<String>,
        /// Only within R metres of ground point X,Y (KITTI x and z): `--near X,Y,R`.
        #[arg(long, value_parser = parse_near)]
        near: Option<([f64; 2], f64)>,
        /// Sentence embedder; default: the one the map was built with.
        #[arg(long, value_parser = ["minilm", "hash"])]
        embedder: Option<String>,
        #[command(flatten)]
        rank: RankArgs,
        #[command(flatten)]
        llm: LlmArgs,
        /// Print a JSON array of results: {"id", "caption", "class", "score", "centroid",
        /// "similarity", "segment", "segment_match", "evidence"}; the parsed request goes to
        /// stderr.
        #[arg(long)]
        json: bool,
    },
    /// Where am I? Road segments ranked for a description of the surroundings ("I'm at a
    /// T-junction, there's a bus stop on my left and a red car parked opposite"): segment kind
    /// and landmarks matched against the map, with a position estimate and evidence.
    Locate {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// The description.
        text: String,
        /// How many segments.
        #[arg(short, long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=1000))]
        k: u64,
        /// Who parses the description: the rule parser or the language model.
        #[arg(long, value_parser = ["rules", "llm"], default_value = "rules")]
        parser: String,
        #[command(flatten)]
        llm: LlmArgs,
        /// Print the answer as JSON: {"description", "parsed_by", "results": [{"segment",
        /// "kind", "score", "kind_match", "position", "evidence"}], "timings_ms"}.
        #[arg(long)]
        json: bool,
    },
    /// The agent tools (names, descriptions, JSON Schemas of their arguments) that the MCP
    /// server and `ask` offer, as JSON.
    Tools {
        /// Include the write tools.
        #[arg(long)]
        writes: bool,
    },
    /// Call one agent tool on a map with JSON arguments and print its JSON answer (what an MCP
    /// client gets).
    Tool {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// The tool's name (see `opengraph tools`).
        name: String,
        /// Its arguments as a JSON object.
        #[arg(default_value = "{}")]
        args: String,
        /// Enable the write tools (opens the store for writing).
        #[arg(long)]
        writes: bool,
    },
    /// Serve the map's agent tools over MCP on stdin/stdout (for Claude Desktop, IDE agents
    /// and the like; see docs/serve.md). Read-only unless --allow-writes.
    Mcp {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// Offer write_cypher (opens the store for writing).
        #[arg(long)]
        allow_writes: bool,
    },
    /// Update the map from a described change ("the bush under the street sign at the
    /// crossing is gone", "the bench by the bus stop is now red", "there is a new bin next to
    /// the post box"): shows the proposed edit; --apply commits it as one transaction and
    /// prints its edit id; --undo ID reverts an edit exactly; --list shows the edits.
    Update {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// The described change.
        #[arg(required_unless_present_any = ["undo", "list"])]
        text: Option<String>,
        /// Commit the proposed edit (an ambiguous description changes nothing; exit 2).
        #[arg(long)]
        apply: bool,
        /// Revert this edit (a MapEdit node id).
        #[arg(long, conflicts_with_all = ["text", "apply", "list"])]
        undo: Option<u64>,
        /// List the recorded edits.
        #[arg(long, conflicts_with_all = ["text", "apply"])]
        list: bool,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Serve the map over HTTP: a JSON API (routes in /openapi.json), MCP over streamable HTTP
    /// at /mcp. Binds 127.0.0.1 unless told otherwise; read-only unless a write token is given
    /// (--token-file; send it as `Authorization: Bearer <token>`). See docs/serve.md.
    Serve {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// Address to listen on; port 0 picks a free port (the address is printed).
        #[arg(long, default_value = "127.0.0.1:7878")]
        bind: std::net::SocketAddr,
        /// A file holding the write token (16 characters or more). Without it the server is
        /// read-only; a non-loopback --bind needs it.
        #[arg(long)]
        token_file: Option<PathBuf>,
        /// Refuse writes even with a token (the store is opened read-only).
        #[arg(long)]
        read_only: bool,
        /// Requests served side by side (each worker holds a sentence embedder, ~100 MB);
        /// default: the number of cores.
        #[arg(long)]
        workers: Option<usize>,
        /// Seconds a request may wait and run.
        #[arg(long, default_value_t = 30.0)]
        timeout_secs: f64,
        /// The largest request body in bytes.
        #[arg(long, default_value_t = 1 << 20)]
        body_limit_bytes: usize,
        /// Requests in progress at once; more get 503.
        #[arg(long, default_value_t = 64)]
        max_concurrent: usize,
        /// A browser origin allowed to call the API (CORS); repeat for more. Default: CORS off.
        #[arg(long)]
        cors_origin: Vec<String>,
    },
    /// Ask a question about the map in words; a language model answers by calling the agent
    /// tools (find_objects, locate, plan_route, read_cypher, ...). Prints each tool call and the
    /// answer; --json prints the whole transcript.
    Ask {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// The question.
        question: String,
        /// Rounds of tool calls before giving up.
        #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u64).range(1..=20))]
        max_steps: u64,
        #[command(flatten)]
        llm: LlmArgs,
        /// Print {"question", "model", "steps", "answer", "stopped", "transcript"} as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Run a Cypher statement against a store and print a table (or JSON rows).
    Query {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// A parameter `name=value` for `$name`; the value is read as JSON when it parses as
        /// JSON (3, 2.5, "x", [1,2], {"a":1}, true, null), else as a plain string. Repeatable.
        #[arg(long = "param", value_parser = parse_param)]
        params: Vec<(String, graphstore::cypher::Val)>,
        /// Print a JSON array of row objects keyed by column.
        #[arg(long)]
        json: bool,
        /// Refuse statements that write.
        #[arg(long)]
        read_only: bool,
        /// Stop the statement after this many seconds (a write is rolled back).
        #[arg(long, default_value_t = 30.0)]
        timeout_secs: f64,
        /// Fail when the result has more rows than this (add LIMIT).
        #[arg(long, default_value_t = 100_000)]
        max_rows: usize,
        /// The statement; `EXPLAIN <statement>` prints its plan.
        cypher: String,
    },
    /// Evaluate a map.
    Eval {
        #[command(subcommand)]
        what: EvalCommand,
    },
    /// Make a new, empty store to try Cypher on (as `sqlite3 new.db` or a fresh Neo4j):
    /// `opengraph query --db new.og "CREATE (:Place {name: 'home'})"`. With --schema opengraph
    /// it carries the OpenGraph map schema (labels, constraints, indexes).
    Init {
        /// The store file to create (must not exist yet).
        #[arg(long)]
        db: PathBuf,
        /// `none` (schema-free) or `opengraph` (the map schema).
        #[arg(long, default_value = "none", value_parser = ["none", "opengraph"])]
        schema: String,
    },
    /// Build a small hand-made demo graph with the OpenGraph schema (a stand-in until
    /// `sim` exists), then print its summary.
    Demo {
        /// The store file to create (must not exist yet).
        #[arg(long)]
        db: PathBuf,
    },
}

#[derive(Debug, Subcommand)]
enum EvalCommand {
    /// Agreement of the map's LLM relations, and of the geometric labels of the same pairs,
    /// with the relations that follow from the simulator's ground-truth boxes (inside, on,
    /// under, next to, near).
    Relations {
        /// The store file (built from the simulator's detections, after `relations`).
        #[arg(long)]
        db: PathBuf,
        /// The simulator's output folder (with ground_truth/objects.json).
        #[arg(long)]
        sim: PathBuf,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Attribute accuracy of the map's object captions (colour, material, noun) against the
    /// simulator's ground truth; after an LLM merge, the medoid captions on the same objects.
    Captions {
        /// The store file (built from the simulator's detections).
        #[arg(long)]
        db: PathBuf,
        /// The simulator's output folder (with ground_truth/objects.json).
        #[arg(long)]
        sim: PathBuf,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Retrieval R@1/2/3 per query type (named, relational, functional) against the
    /// simulator's objects: a hit is a returned instance lying on an object that satisfies
    /// the query's predicate. Queries: JSON Lines (see ingest/data/retrieval_small_city.jsonl).
    Retrieval {
        /// The store file (built from the simulator's detections).
        #[arg(long)]
        db: PathBuf,
        /// The simulator's output folder (with ground_truth/objects.json).
        #[arg(long)]
        sim: PathBuf,
        /// The query file.
        #[arg(long)]
        queries: PathBuf,
        #[command(flatten)]
        rank: RankArgs,
        #[command(flatten)]
        llm: LlmArgs,
        /// Print every query's outcome.
        #[arg(long)]
        verbose: bool,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Localisation top-1/top-3 against the simulator: descriptions generated from its ground
    /// truth (junction kinds and the objects near true spots, paraphrased, some left out) and
    /// the map segment that holds each spot.
    Locate {
        /// The store file (built from the simulator's detections).
        #[arg(long)]
        db: PathBuf,
        /// The simulator's output folder (with ground_truth/roads.json and objects.json).
        #[arg(long)]
        sim: PathBuf,
        /// Descriptions per spot.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=20))]
        per_spot: u64,
        /// Seed of the description generator.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Who parses the descriptions.
        #[arg(long, value_parser = ["rules", "llm"], default_value = "rules")]
        parser: String,
        #[command(flatten)]
        llm: LlmArgs,
        /// Print every description's outcome.
        #[arg(long)]
        verbose: bool,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Instance precision and recall against the simulator's objects: map instances (not
    /// surface tiles) and true objects matched one-to-one by ground-footprint IoU >= 0.5;
    /// recall per true class, precision per map class.
    Instances {
        /// The store file (built from the simulator's detections).
        #[arg(long)]
        db: PathBuf,
        /// The simulator's output folder (with ground_truth/objects.json).
        #[arg(long)]
        sim: PathBuf,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Per-class IoU, mean IoU and macro F1 of the map against SemanticKITTI labels.
    Semseg {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// The sequence directory with labels/.
        #[arg(long)]
        kitti: PathBuf,
        /// Only these frames A..B (half-open).
        #[arg(long, value_parser = parse_range)]
        frames: Option<std::ops::Range<u32>>,
        /// poses.txt from another path.
        #[arg(long)]
        poses: Option<PathBuf>,
        /// A labelled point takes the class of the nearest map point within this radius.
        #[arg(long, default_value_t = 0.3)]
        max_dist_m: f32,
        /// Print `{"miou", "f1", "per_class", "source", ...}`.
        #[arg(long)]
        json: bool,
    },
}

/// How `find` and `eval retrieval` rank.
#[derive(clap::Args, Debug, Clone)]
struct RankArgs {
    /// Rank by the cosine of the whole text with each instance's feature only (no parsing,
    /// no graph).
    #[arg(long, conflicts_with_all = ["parser", "rerank"])]
    plain: bool,
    /// Who parses the request: the rule parser or the language model.
    #[arg(long, value_parser = ["rules", "llm"], default_value = "rules")]
    parser: String,
    /// Re-rank with a language model (OpenGraph-LLM): it picks the best three of the first
    /// --rerank-n results.
    #[arg(long, value_parser = ["llm"])]
    rerank: Option<String>,
    /// Results shown to the re-ranking model.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(2..=30))]
    rerank_n: u64,
}

impl RankArgs {
    fn ranking(&self) -> api::find::Ranking {
        ranking_of(self.plain, &self.parser, self.rerank.is_some())
    }
}

/// Planner settings shared by `plan` and `navigate`; each is checked (finite, in range)
/// before any work.
#[derive(clap::Args, Debug, Clone)]
struct PlanArgs {
    /// Minimum turning radius of the vehicle, metres, in [0.5, 100].
    #[arg(long, default_value_t = 5.0, value_parser = in_range(0.5, 100.0), allow_hyphen_values = true)]
    turning_radius_m: f64,
    /// Time budget for OMPL, milliseconds, in [0, 60000]; 0 returns the route polyline as a
    /// fallback.
    #[arg(long, default_value_t = 200.0, value_parser = in_range(0.0, 60000.0), allow_hyphen_values = true)]
    budget_ms: f64,
    /// Half-width of the corridor around the route the path must stay in, metres, in
    /// [0.5, 100].
    #[arg(long, default_value_t = 6.0, value_parser = in_range(0.5, 100.0), allow_hyphen_values = true)]
    corridor_m: f64,
    /// Points farther than this from every lane are refused, metres, in [0, 1000].
    #[arg(long, default_value_t = 15.0, value_parser = in_range(0.0, 1000.0), allow_hyphen_values = true)]
    snap_m: f64,
    /// Draw the map (instances in SemanticKITTI class colours), the lane graph, the route
    /// (blue), the path, the boxes that block it, the start (green) and the goal (red).
    #[arg(long)]
    png: Option<PathBuf>,
}

impl PlanArgs {
    fn options(&self) -> api::plan::PlanOptions {
        api::plan::PlanOptions {
            turning_radius_m: self.turning_radius_m,
            budget_ms: self.budget_ms,
            corridor_m: self.corridor_m,
            snap_m: self.snap_m,
            png: self.png.clone(),
        }
    }
}

/// A clap parser for a finite number in `[lo, hi]`.
fn in_range(lo: f64, hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone {
    move |s: &str| {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("{s:?} is not a number"))?;
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(format!("{s} is outside [{lo}, {hi}]"))
        }
    }
}

/// Which language model to use: the same three flags on every command that needs one.
#[derive(clap::Args, Debug, Clone, Default)]
struct LlmArgs {
    /// Language model: local (llama.cpp on a GGUF file), openai (an OpenAI-compatible server:
    /// OPENAI_BASE_URL, OPENAI_MODEL, OPENAI_API_KEY) or none.
    #[arg(long, value_parser = ["local", "openai", "none"])]
    llm: Option<String>,
    /// For local: the GGUF file (default: the default model that scripts/setup.sh fetched);
    /// for openai: the model name.
    #[arg(long)]
    llm_model: Option<String>,
    /// For openai: the server's base URL, e.g. http://127.0.0.1:8080/v1.
    #[arg(long)]
    llm_url: Option<String>,
}

impl LlmArgs {
    /// The flags laid over `base` (the `[llm]` table of a config, or the default).
    fn config(
        &self,
        mut base: llm_tools::LlmConfig,
        default_backend: &str,
    ) -> llm_tools::LlmConfig {
        if let Some(b) = &self.llm {
            base.backend = b.clone();
        } else if base.backend == "none" {
            base.backend = default_backend.to_string();
        }
        if let Some(m) = &self.llm_model {
            if base.backend == "local" {
                base.model_path = Some(PathBuf::from(m));
            } else {
                base.model = Some(m.clone());
            }
        }
        if let Some(u) = &self.llm_url {
            base.url = Some(u.clone());
        }
        base
    }
}

/// Opens the language model `cfg` names; a usage error when it names none.
fn open_llm(
    cfg: &llm_tools::LlmConfig,
    what: &str,
) -> anyhow::Result<Box<dyn llm_tools::ChatModel>> {
    match llm_tools::chat::open(cfg)? {
        Some(m) => {
            errln!("language model: {}", m.model_id());
            Ok(m)
        }
        None => Err(UsageError(format!(
            "{what} needs a language model: pass --llm local (or openai with --llm-url)"
        ))
        .into()),
    }
}

fn parse_budget(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("{s:?} is not a number of seconds"))?;
    if v.is_finite() && v > 0.0 && v <= 7.0 * 86400.0 {
        Ok(v)
    } else {
        Err(format!(
            "{s}: the budget must be a finite number of seconds in (0, 604800]"
        ))
    }
}

fn print_pass(name: &str, r: &ingest::llm::PassReport) -> anyhow::Result<()> {
    outln!(
        "{name}: {} done in this run ({} from the cache), {} done before, {} left of {}; {:.0} ms per question, {:.1} s in all\nmodel {}, prompt {}",
        r.done,
        r.cached,
        r.already_done,
        r.left,
        r.total,
        r.ms_per_item,
        r.secs,
        r.model,
        r.prompt
    );
    for (label, n) in &r.labels {
        outln!("  {label:<24} {n}");
    }
    if !r.rejected.is_empty() {
        errln!(
            "{} answers broke the answer schema and were skipped (a later run asks again):",
            r.rejected.len()
        );
        for why in r.rejected.iter().take(5) {
            errln!("  {why}");
        }
    }
    Ok(())
}

fn parse_near(s: &str) -> Result<([f64; 2], f64), String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("expected X,Y,R in metres: {e}"))?;
    match v[..] {
        [x, y, r] if v.iter().all(|a| a.is_finite()) && r >= 0.0 => Ok(([x, y], r)),
        _ => Err("expected X,Y,R: three finite numbers, R >= 0".into()),
    }
}

/// Prints a plan: JSON, or the ends (with how `navigate` resolved them), route and path.
fn print_plan(
    p: &api::plan::PlanAnswer,
    json: bool,
    resolved: Option<(&api::plan::Resolved, &api::plan::Resolved)>,
) -> anyhow::Result<()> {
    if let Some(w) = &p.path.warning {
        errln!("warning: {w}");
    }
    if json {
        let v = serde_json::json!({
            "from": p.from,
            "to": p.to,
            "route": {"nodes": p.route.nodes, "length_m": p.route.length_m},
            "path": {"poses": p.path.poses, "length_m": p.path.length_m, "planner": p.path.planner},
        });
        outln!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    let end = |t: &planner::Target| match t.node {
        Some(n) => format!("{} node {n} at ({:.1}, {:.1})", t.kind, t.xy[0], t.xy[1]),
        None => format!("point ({:.1}, {:.1})", t.xy[0], t.xy[1]),
    };
    let how = |r: Option<&api::plan::Resolved>| match r {
        Some(api::plan::Resolved::Find { text, result }) => {
            format!("  <- find {text:?}: {}", result.caption)
        }
        Some(api::plan::Resolved::Locate { text, result }) => {
            format!("  <- locate {text:?}: {} segment", result.kind)
        }
        _ => String::new(),
    };
    outln!(
        "from: {}{}\nto:   {}{}",
        end(&p.from),
        how(resolved.map(|r| r.0)),
        end(&p.to),
        how(resolved.map(|r| r.1))
    );
    outln!(
        "route: {} nodes, {:.1} m ({:.1} ms)\npath: {} poses, {:.1} m by {} ({:.1} ms in all, {} blocking boxes)",
        p.route.nodes.len(),
        p.route.length_m,
        p.timings_ms[0],
        p.path.poses.len(),
        p.path.length_m,
        p.path.planner,
        p.timings_ms[1],
        p.blocking
    );
    Ok(())
}

/// The ranking the find flags ask for.
fn ranking_of(plain: bool, parser: &str, rerank: bool) -> api::find::Ranking {
    if plain {
        api::find::Ranking::Plain
    } else {
        api::find::Ranking::Graph {
            parser: if parser == "llm" {
                api::find::ParserKind::Llm
            } else {
                api::find::ParserKind::Rules
            },
            rerank,
        }
    }
}

/// Opens a map for writing or read-only, naming the file in the error. When a server holds
/// the map (its marker file [`serving_marker`] exists), the error says where to reach it.
fn open_store(db: &std::path::Path, writable: bool) -> anyhow::Result<graphstore::Store> {
    let opened = if writable {
        graphstore::Store::open(db)
    } else {
        graphstore::Store::open_read_only(db)
    };
    match opened {
        Err(e @ graphstore::Error::InUse { .. }) => {
            let served = std::fs::read_to_string(serving_marker(db))
                .ok()
                .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
                .and_then(|v| v["url"].as_str().map(str::to_string));
            match served {
                Some(url) => Err(anyhow::Error::new(e).context(format!(
                    "opening {}: `opengraph serve` holds it; reach the map through the server at {url} \
                     (POST {url}api/cypher with {{\"query\": ...}}, the routes are in {url}openapi.json, MCP at {url}mcp)",
                    db.display()
                ))),
                None => Err(anyhow::Error::new(e).context(format!("opening {}", db.display()))),
            }
        }
        other => other.with_context(|| format!("opening {}", db.display())),
    }
}

/// The file a writing server leaves beside the map (`MAP.serving.json`: url, pid) while it
/// holds it, so that other commands can say where to reach it.
fn serving_marker(db: &std::path::Path) -> PathBuf {
    let mut name = db.file_name().unwrap_or_default().to_os_string();
    name.push(".serving.json");
    db.with_file_name(name)
}

/// Opens a map read-only (several readers may share it), naming the file in the error.
fn open_read(db: &std::path::Path) -> anyhow::Result<graphstore::Store> {
    open_store(db, false)
}

/// The median of some latencies (0 for none); sorts them.
fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(0.0)
}

/// The toolbox over a map: read-only unless `writes`.
fn open_toolbox(db: &std::path::Path, writes: bool) -> anyhow::Result<api::tools::Toolbox> {
    let store = open_store(db, writes)?;
    let finder = {
        let r = store.read()?;
        finder_for(&r, None, false, &LlmArgs::default())?
    };
    Ok(api::tools::Toolbox::new(store, finder, writes))
}

/// `opengraph serve`'s arguments.
struct ServeArgs {
    db: PathBuf,
    bind: std::net::SocketAddr,
    token_file: Option<PathBuf>,
    read_only: bool,
    workers: Option<usize>,
    timeout_secs: f64,
    body_limit_bytes: usize,
    max_concurrent: usize,
    cors_origin: Vec<String>,
}

/// Reads a write token from a file: trimmed, 16 characters or more, printable ASCII.
fn read_token(path: &std::path::Path) -> anyhow::Result<String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| UsageError(format!("reading the token file {}: {e}", path.display())))?;
    let token = text.trim().to_string();
    if token.len() < 16 || !token.bytes().all(|b| b.is_ascii_graphic()) {
        return Err(UsageError(format!(
            "the token in {} must be 16 or more printable characters without spaces (e.g. `openssl rand -hex 32 > {}`)",
            path.display(),
            path.display()
        ))
        .into());
    }
    Ok(token)
}

/// `opengraph serve`: opens the map, checks every setting, then serves until Ctrl-C.
fn serve(a: ServeArgs) -> anyhow::Result<()> {
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
    ] {
        if v == 0 || v > max {
            return Err(UsageError(format!("{name} must be between 1 and {max} (got {v})")).into());
        }
    }
    let token = a.token_file.as_deref().map(read_token).transpose()?;
    api::http::check_bind(&a.bind, token.as_deref()).map_err(UsageError)?;
    let writes = token.is_some() && !a.read_only;
    let workers = a.workers.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(2)
            .min(8)
    });
    let first = open_toolbox(&a.db, writes)?;
    let mut boxes = Vec::with_capacity(workers);
    for _ in 1..workers {
        let finder = {
            let r = first.store().read()?;
            finder_for(&r, None, false, &LlmArgs::default())?
        };
        boxes.push(first.fork(finder));
    }
    boxes.push(first);
    let service =
        api::service::Service::new(boxes, std::time::Duration::from_secs_f64(a.timeout_secs))
            .context("no workers")?;
    let opts = api::http::ServeOptions {
        bind: a.bind,
        token,
        body_limit_bytes: a.body_limit_bytes,
        max_concurrent: a.max_concurrent,
        cors_origins: a.cors_origin,
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
        let app = api::http::router(service, &opts);
        // a writing server holds the file's lock: leave a note where to reach it
        let marker = writes.then(|| serving_marker(&a.db));
        if let Some(m) = &marker {
            let note = serde_json::json!({"url": format!("http://{addr}/"), "pid": std::process::id()});
            if let Err(e) = std::fs::write(m, note.to_string()) {
                errln!("note: could not write {}: {e}", m.display());
            }
        }
        outln!("serving {} on http://{addr}/ (MCP: http://{addr}/mcp; API: http://{addr}/openapi.json)", a.db.display());
        errln!(
            "{workers} workers, {}; Ctrl-C stops",
            if writes {
                "writes need the token"
            } else {
                "read-only"
            }
        );
        api::http::serve(listener, app, async {
            shutdown_signal().await;
        })
        .await?;
        if let Some(m) = &marker {
            let _ = std::fs::remove_file(m);
        }
        errln!("stopped");
        anyhow::Ok(())
    })
}

/// Resolves on Ctrl-C or SIGTERM.
async fn shutdown_signal() {
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

/// Whether a ranking needs a language model.
fn needs_llm(ranking: api::find::Ranking) -> bool {
    matches!(
        ranking,
        api::find::Ranking::Graph {
            parser: api::find::ParserKind::Llm,
            ..
        } | api::find::Ranking::Graph { rerank: true, .. }
    )
}

fn parser_of(name: &str) -> api::find::ParserKind {
    if name == "llm" {
        api::find::ParserKind::Llm
    } else {
        api::find::ParserKind::Rules
    }
}

/// A finder with the map's embedder (or the one asked for, if it agrees) and, when the
/// ranking needs one, the language model.
fn finder_for(
    r: &impl graphstore::GraphRead,
    embedder: Option<String>,
    needs_llm: bool,
    llm: &LlmArgs,
) -> anyhow::Result<api::find::Finder> {
    let built = llm_tools::retrieve::map_embedder(r)?;
    let name = match (embedder, built) {
        (Some(e), Some(b)) if e != b => {
            return Err(UsageError(format!(
                "the map was built with the {b} embedder; query it with the same one (--embedder {b})"
            ))
            .into());
        }
        (Some(e), _) => e,
        (None, b) => b.unwrap_or_else(|| "minilm".into()),
    };
    let model = if needs_llm {
        Some(open_llm(
            &llm.config(llm_tools::LlmConfig::default(), "local"),
            "--parser llm and --rerank llm",
        )?)
    } else {
        None
    };
    Ok(api::find::Finder::new(make_embedder(&name)?, model))
}

fn make_embedder(name: &str) -> anyhow::Result<Box<dyn llm_tools::Embedder + Send>> {
    Ok(match name {
        "hash" => Box::new(llm_tools::HashEmbedder::new(graphstore::FEATURE_DIM)),
        _ => Box::new(
            llm_tools::MiniLm::from_dir(&llm_tools::embed::default_models_dir())
                .context("loading the sentence embedder")?,
        ),
    })
}

fn parse_range(s: &str) -> Result<std::ops::Range<u32>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("{s:?} is not a range A..B"))?;
    let n = |x: &str| {
        x.trim()
            .parse::<u32>()
            .map_err(|_| format!("{x:?} is not a frame number"))
    };
    let (a, b) = (n(a)?, n(b)?);
    if a >= b {
        return Err(format!("{s}: the range is empty (A..B is half-open)"));
    }
    Ok(a..b)
}

/// Peak resident memory of this process in MiB (Linux), if known.
fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Whether an error is a write to a closed pipe.
fn is_closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Errors caused by what the user gave us (exit code 2), as opposed to internal failures (1).
fn is_input_error(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        if let Some(g) = c.downcast_ref::<graphstore::Error>() {
            return !matches!(
                g,
                graphstore::Error::Storage(_) | graphstore::Error::Io { .. }
            );
        }
        if let Some(p) = c.downcast_ref::<planner::Error>() {
            return !matches!(
                p,
                planner::Error::Render(_) | planner::Error::Store(graphstore::Error::Storage(_))
            );
        }
        if let Some(l) = c.downcast_ref::<llm_tools::Error>() {
            return llm_input_error(l);
        }
        if let Some(i) = c.downcast_ref::<ingest::Error>() {
            return match i {
                ingest::Error::Llm(l) => llm_input_error(l),
                _ => !matches!(
                    i,
                    ingest::Error::Render(_) | ingest::Error::Store(graphstore::Error::Storage(_))
                ),
            };
        }
        c.downcast_ref::<UsageError>().is_some()
    })
}

/// Missing or bad model files, bad settings and requests a server refuses are the user's to
/// fix (exit 2); a model or server failing on a good request is not.
fn llm_input_error(e: &llm_tools::Error) -> bool {
    matches!(
        e,
        llm_tools::Error::ModelMissing { .. }
            | llm_tools::Error::BadModel { .. }
            | llm_tools::Error::Invalid(_)
            | llm_tools::Error::LlmHttp { .. }
    )
}

fn parse_param(s: &str) -> Result<(String, graphstore::cypher::Val), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("--param takes name=value, got {s:?}"))?;
    let k = k.trim().trim_start_matches('$');
    if k.is_empty() || !k.chars().all(|c| c.is_alphanumeric() || c == '_') {
        return Err(format!("--param: {k:?} is not a parameter name"));
    }
    let v = graphstore::cypher::param_from_text(v).map_err(|e| format!("--param {k}: {e}"))?;
    Ok((k.to_string(), v))
}

/// Shortens a rendered cell for the table view.
fn cell(text: String) -> String {
    const MAX: usize = 60;
    if text.chars().count() <= MAX {
        text
    } else {
        let mut t: String = text.chars().take(MAX - 1).collect();
        t.push('…');
        t
    }
}

/// A problem with the arguments that clap cannot see.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct UsageError(String);

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Info { db, json } => {
            let store = open_read(&db)?;
            let text = if json {
                info::json(&store)?
            } else {
                info::table(&store)?
            };
            out!("{text}");
        }
        Command::Export {
            db,
            format,
            out,
            edges_key,
        } => {
            let store = open_read(&db)?;
            let fmt: graphstore::export::ExportFormat = format.parse()?;
            let file = std::fs::File::create(&out)
                .with_context(|| format!("creating {}", out.display()))?;
            let mut w = std::io::BufWriter::new(file);
            let r = store.read()?;
            let (n, m) = match fmt {
                graphstore::export::ExportFormat::NodeLink => {
                    graphstore::export::export_node_link(&r, &edges_key, &mut w)?
                }
                other => graphstore::export::export(&r, other, &mut w)?,
            };
            use std::io::Write;
            w.flush()
                .with_context(|| format!("writing {}", out.display()))?;
            errln!(
                "exported {n} nodes and {m} relationships to {}",
                out.display()
            );
        }
        Command::Lanes {
            poses,
            calib,
            stride,
            out,
            png,
            json,
        } => {
            use ingest::hierarchy::{lanes, render, segments};
            let world = ingest::sources::kitti::load_trajectory(&poses, calib.as_deref())?;
            let frame = ingest::hierarchy::frame::GroundFrame::KittiCam;
            let full: Vec<[f64; 2]> = world.iter().map(|p| frame.ground(*p)).collect();
            let traj: Vec<[f64; 2]> = full.iter().step_by(stride as usize).copied().collect();
            let t0 = std::time::Instant::now();
            let mut g = lanes::extract_lanes(&traj, &lanes::LaneConfig::default())?;
            let segs = segments::build_segments(&g, &segments::SegmentConfig::default());
            let took = t0.elapsed();
            for e in &mut g.edges {
                for f in &mut e.frames {
                    *f *= stride;
                }
            }
            let gj = render::geojson(&g, Some(&segs));
            std::fs::write(&out, serde_json::to_vec_pretty(&gj)?)
                .with_context(|| format!("writing {}", out.display()))?;
            if let Some(png) = &png {
                render::write_png(png, &full, &g, Some(&segs))?;
            }
            if json {
                outln!("{}", serde_json::to_string_pretty(&render::lanes_json(&g))?);
            } else {
                let kinds: Vec<String> = g
                    .kind_counts()
                    .iter()
                    .map(|(k, n)| format!("{} {n}", k.as_str()))
                    .collect();
                outln!(
                    "{} poses -> {} lane nodes ({}), {} lane edges ({:.0} m), {} segments, in {:.1} ms",
                    full.len(),
                    g.nodes.len(),
                    kinds.join(", "),
                    g.edges.len(),
                    g.edges.iter().map(|e| e.length_m).sum::<f64>(),
                    segs.segments.len(),
                    took.as_secs_f64() * 1e3
                );
            }
        }
        Command::Hierarchy {
            db,
            poses,
            calib,
            name,
            json,
        } => {
            let traj = ingest::sources::kitti::load_trajectory(&poses, calib.as_deref())?;
            let store = graphstore::Store::create(&db)
                .with_context(|| format!("opening {}", db.display()))?;
            if store.schema() == graphstore::Schema::default() {
                store.set_schema(graphstore::opengraph_schema())?;
            }
            let (_, _, report) = ingest::hierarchy::build_hierarchy(
                &store,
                &traj,
                ingest::hierarchy::frame::GroundFrame::KittiCam,
                &name,
                &ingest::hierarchy::HierarchyConfig::default(),
            )?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                outln!("{report:?}");
            }
        }
        Command::Plan {
            db,
            from,
            to,
            opts,
            json,
        } => {
            let store = open_read(&db)?;
            let r = store.read()?;
            let (a, b) = (from.parse::<planner::Spec>()?, to.parse::<planner::Spec>()?);
            let p = api::plan::plan(&r, &a, &b, &opts.options())?;
            print_plan(&p, json, None)?;
        }
        Command::Navigate {
            db,
            text,
            from,
            to,
            parser,
            llm,
            opts,
            json,
        } => {
            let words = match &text {
                Some(t) => Some(llm_tools::request::parse_route(t)?),
                None => None,
            };
            let from = from.or_else(|| words.as_ref().and_then(|w| w.from.clone()));
            let to = to.or_else(|| words.as_ref().map(|w| w.to.clone()));
            let (Some(from), Some(to)) = (from, to) else {
                return Err(UsageError(
                    "say where to start and where to go: \"from A to B\" in the text, or --from and --to (words or specs such as lane:ID)".into(),
                )
                .into());
            };
            let store = open_read(&db)?;
            let r = store.read()?;
            let parser = parser_of(&parser);
            let mut finder = finder_for(&r, None, parser == api::find::ParserKind::Llm, &llm)?;
            let (a, start) = api::plan::resolve_end(&mut finder, &r, &from, parser)?;
            let (b, goal) = api::plan::resolve_end(&mut finder, &r, &to, parser)?;
            let p = api::plan::plan(&r, &a, &b, &opts.options())?;
            if json {
                let v = api::plan::NavigateAnswer {
                    start,
                    goal,
                    plan: p,
                };
                outln!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                print_plan(&p, false, Some((&start, &goal)))?;
            }
        }
        Command::Build {
            kitti,
            detections,
            oracle_labels,
            frames,
            stride,
            accumulate,
            poses,
            config,
            db,
            resume,
            name,
            embedder,
            llm,
            json,
        } => {
            use ingest::build::{BuildArgs, BuildConfig, Progress, Source};
            let mut cfg = match &config {
                Some(p) => BuildConfig::from_toml_file(p)?,
                None => BuildConfig::default(),
            };
            // the language model is opened before any mapping, so a bad [llm] or --llm fails
            // at once instead of after the whole build
            let llm_cfg = llm.config(cfg.llm.clone(), "none");
            let mut chat = llm_tools::chat::open(&llm_cfg)?;
            if let Some(m) = &chat {
                errln!("language model for the caption merge: {}", m.model_id());
            }
            if let Some(a) = accumulate {
                cfg.mapping.accumulate = a as usize;
            }
            let source = match (detections, oracle_labels) {
                (Some(d), false) => Source::Detections(d),
                (None, true) => Source::Oracle,
                _ => {
                    return Err(UsageError(
                        "give either --detections DIR or --oracle-labels".into(),
                    )
                    .into());
                }
            };
            let mut emb = make_embedder(&embedder)?;
            let store = graphstore::Store::create(&db)
                .with_context(|| format!("opening {}", db.display()))?;
            let args = BuildArgs {
                sequence: kitti,
                poses,
                source,
                frames,
                stride,
                config: cfg,
                environment: name,
            };
            // test hook: pause after each commit so a test can kill the build at a known point
            let pause_ms: u64 = std::env::var("OPENGRAPH_BUILD_PAUSE_AFTER_COMMIT_MS")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(0);
            let bar = indicatif::ProgressBar::new(0);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} key frames {msg}",
                )
                .expect("valid template"),
            );
            let mut on_progress = |p: Progress| match p {
                Progress::Start { done, total } => {
                    bar.set_length(total as u64);
                    bar.set_position(done as u64);
                }
                Progress::Frame { frame } => {
                    bar.inc(1);
                    bar.set_message(format!("frame {frame}"));
                }
                Progress::Committed { frame } => {
                    bar.suspend(|| errln!("committed through frame {frame}"));
                    if pause_ms > 0 {
                        std::thread::sleep(std::time::Duration::from_millis(pause_ms));
                    }
                }
                Progress::Finishing => bar.set_message("post-processing and hierarchy"),
            };
            let mut merger = ingest::mapping::MedoidMerger;
            let report = ingest::build::build(
                &store,
                &args,
                emb.as_mut(),
                &mut merger,
                resume,
                &mut on_progress,
            )?;
            bar.finish_and_clear();
            let merge = match chat.as_mut() {
                Some(m) => Some(ingest::llm::merge_captions(
                    &store,
                    m.as_mut(),
                    emb.as_mut(),
                    args.config.mapping.merge_captions.max(2),
                    &ingest::llm::PassOptions::default(),
                )?),
                None => None,
            };
            let rss = peak_rss_mib();
            if json {
                let mut v = serde_json::to_value(&report)?;
                v["peak_rss_mib"] = serde_json::json!(rss);
                v["caption_merge"] = match &merge {
                    Some(m) => serde_json::to_value(m)?,
                    None => serde_json::json!({"model": "none", "method": "medoid"}),
                };
                outln!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                out!("{}", build_summary(&report, rss));
                match &merge {
                    Some(m) => print_pass("caption merge", m)?,
                    None => {
                        outln!("captions: medoid of each object's latest captions (no --llm)")
                    }
                }
            }
        }
        Command::Relations {
            db,
            llm,
            budget_secs,
            max_pairs,
            json,
        } => {
            let cfg = llm.config(llm_tools::LlmConfig::default(), "local");
            let mut m = open_llm(&cfg, "relations")?;
            let store = open_store(&db, true)?;
            let opts = ingest::llm::PassOptions {
                budget: budget_secs.map(std::time::Duration::from_secs_f64),
                max_items: max_pairs.map(|n| n as usize),
                ..ingest::llm::PassOptions::default()
            };
            let r = ingest::llm::infer_relations(
                &store,
                m.as_mut(),
                &ingest::hierarchy::relations::RelationConfig::default(),
                &opts,
            )?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&r)?);
            } else {
                print_pass("relations", &r)?;
            }
        }
        Command::Captions {
            db,
            llm,
            recent,
            budget_secs,
            max_items,
            json,
        } => {
            let cfg = llm.config(llm_tools::LlmConfig::default(), "local");
            let mut m = open_llm(&cfg, "captions")?;
            let store = open_store(&db, true)?;
            let name = llm_tools::retrieve::map_embedder(&store.read()?)?
                .unwrap_or_else(|| "minilm".into());
            let mut emb = make_embedder(&name)?;
            let opts = ingest::llm::PassOptions {
                budget: budget_secs.map(std::time::Duration::from_secs_f64),
                max_items: max_items.map(|n| n as usize),
                ..ingest::llm::PassOptions::default()
            };
            let r = ingest::llm::merge_captions(
                &store,
                m.as_mut(),
                emb.as_mut(),
                recent as usize,
                &opts,
            )?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&r)?);
            } else {
                print_pass("caption merge", &r)?;
            }
        }
        Command::Sim {
            out,
            seed,
            size,
            frames,
            miss_rate,
            false_positives,
            paraphrase_rate,
            wrong_attribute_rate,
            mask_noise_px,
            no_noise,
            threads,
            json,
        } => {
            use ingest::sources::sim::{
                SimConfig, generate, roads::SimSize, sensors::DetectionNoise,
            };
            let size = match size.as_str() {
                "medium" => SimSize::Medium,
                "city" => SimSize::City,
                _ => SimSize::Small,
            };
            let mut cfg = SimConfig {
                seed,
                size,
                frames: frames.map(|f| f as usize),
                noise: if no_noise {
                    DetectionNoise::none()
                } else {
                    DetectionNoise {
                        miss_rate,
                        false_positives_per_frame: false_positives,
                        paraphrase_rate,
                        wrong_attribute_rate,
                        mask_noise_px,
                    }
                },
                ..SimConfig::default()
            };
            if let Some(t) = threads {
                cfg.threads = t.max(1);
            }
            std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
            let bar = indicatif::ProgressBar::new(0);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} sensor frames",
                )
                .expect("valid template"),
            );
            let progress = |done: usize, total: usize| {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
            };
            let r = generate(&out, &cfg, &progress)?;
            bar.finish_and_clear();
            if json {
                outln!("{}", serde_json::to_string_pretty(&r)?);
            } else {
                out!("{}", sim_summary(&r));
            }
        }
        Command::Find {
            db,
            text,
            k,
            class,
            near,
            embedder,
            rank,
            llm,
            json,
        } => {
            let store = open_read(&db)?;
            let r = store.read()?;
            let ranking = rank.ranking();
            let rerank_n = rank.rerank_n;
            let mut finder = finder_for(&r, embedder, needs_llm(ranking), &llm)?;
            if let Some(c) = &class
                && !ingest::classes::CLASSES.contains(&c.as_str())
            {
                return Err(UsageError(format!(
                    "--class {c:?} is not one of the 19 SemanticKITTI classes a map's instances carry: {}",
                    ingest::classes::CLASSES.join(", ")
                ))
                .into());
            }
            let req = api::find::FindRequest {
                text,
                k: k as usize,
                class,
                near,
                ranking,
                rerank_n: rerank_n as usize,
            };
            let a = finder.find(&r, &req)?;
            if let Some(p) = &a.request {
                errln!("request: {}", serde_json::to_string(p)?);
            }
            for (what, by) in [("parsed", &a.parsed_by), ("re-ranked", &a.reranked_by)] {
                if let Some(m) = by {
                    errln!("{what} by {m}");
                }
            }
            if json {
                outln!("{}", serde_json::to_string_pretty(&a.results)?);
            } else {
                outln!(
                    "{:>8}  {:>6}  {:<16} {:>26}  caption",
                    "id",
                    "score",
                    "class",
                    "centroid [x, y, z] m"
                );
                for h in &a.results {
                    outln!(
                        "{:>8}  {:>6.3}  {:<16} {:>26}  {}",
                        h.id,
                        h.score,
                        h.class,
                        format!(
                            "[{:.1}, {:.1}, {:.1}]",
                            h.centroid[0], h.centroid[1], h.centroid[2]
                        ),
                        h.caption
                    );
                    if let Some((sid, kind)) = &h.segment
                        && a.request.as_ref().is_some_and(|r| r.segment.is_some())
                    {
                        outln!("{:>18}in segment {sid} ({kind})", "");
                    }
                    for e in &h.evidence {
                        outln!(
                            "{:>18}{} '{}': node {} at {:.1} m ({}){}",
                            "",
                            e.relation.replace('_', " "),
                            e.anchor,
                            e.anchor_id,
                            e.distance_m,
                            e.anchor_caption,
                            e.related
                                .as_ref()
                                .map_or(String::new(), |x| format!(", RELATED {x}"))
                        );
                    }
                }
                errln!(
                    "{} results; parse {:.1} ms, rank {:.1} ms{}",
                    a.results.len(),
                    a.timings_ms[0],
                    a.timings_ms[1],
                    if a.reranked_by.is_some() {
                        format!(", re-rank {:.0} ms", a.timings_ms[2])
                    } else {
                        String::new()
                    }
                );
            }
        }
        Command::Update {
            db,
            text,
            apply,
            undo,
            list,
            json,
        } => {
            if list {
                let store = open_read(&db)?;
                let edits = ingest::map_edit::list(&store.read()?)?;
                if json {
                    outln!("{}", serde_json::to_string_pretty(&edits)?);
                } else if edits.is_empty() {
                    outln!("no map edits");
                } else {
                    for e in &edits {
                        outln!(
                            "edit {:>6}  {:<6}  {}{}",
                            e.edit_id,
                            e.kind,
                            e.text,
                            if e.undone { "  (undone)" } else { "" }
                        );
                    }
                }
                return Ok(());
            }
            let writes = apply || undo.is_some();
            let mut tb = open_toolbox(&db, writes)?;
            let user = |e: api::tools::ToolError| -> anyhow::Error {
                if e.exit_code() == 2 {
                    UsageError(e.to_string()).into()
                } else {
                    e.into()
                }
            };
            if let Some(id) = undo {
                let info = tb
                    .call("undo_map_edit", &serde_json::json!({"edit_id": id}))
                    .map_err(user)?;
                if json {
                    outln!("{}", serde_json::to_string_pretty(&info)?);
                } else {
                    outln!(
                        "undone: edit {id} ({})",
                        info["text"].as_str().unwrap_or_default()
                    );
                }
                return Ok(());
            }
            let text = text.unwrap_or_default();
            let a = if writes {
                tb.call(
                    "update_map",
                    &serde_json::json!({"text": text, "apply": true}),
                )
                .map_err(user)?
            } else {
                // a proposal needs no write access: run the operation on the read-only store
                let (finder, store) = tb.parts();
                serde_json::to_value(
                    api::update::update(
                        finder,
                        store,
                        &api::update::UpdateRequest { text, apply: false },
                    )
                    .map_err(user)?,
                )?
            };
            if json {
                outln!("{}", serde_json::to_string_pretty(&a)?);
            } else {
                outln!("{}", a["proposal"].as_str().unwrap_or_default());
                for key in ["target", "anchor"] {
                    if let Some(cands) = a[key]["candidates"].as_array() {
                        outln!("{key} {:?}:", a[key]["phrase"].as_str().unwrap_or_default());
                        for c in cands {
                            outln!(
                                "  {:>6}  {:.2}  {:<14} {}",
                                c["id"],
                                c["score"].as_f64().unwrap_or_default(),
                                c["class"].as_str().unwrap_or_default(),
                                c["caption"].as_str().unwrap_or_default()
                            );
                        }
                    }
                }
                match a["applied"]["edit_id"].as_u64() {
                    Some(id) => outln!(
                        "applied as edit {id} (undo: opengraph update --db {} --undo {id})",
                        db.display()
                    ),
                    None if apply => {}
                    None => outln!("not applied (add --apply to commit it)"),
                }
            }
            if apply && a["ambiguous"] == true {
                return Err(UsageError(
                    "the description fits several objects; nothing was changed".into(),
                )
                .into());
            }
        }
        Command::Serve {
            db,
            bind,
            token_file,
            read_only,
            workers,
            timeout_secs,
            body_limit_bytes,
            max_concurrent,
            cors_origin,
        } => serve(ServeArgs {
            db,
            bind,
            token_file,
            read_only,
            workers,
            timeout_secs,
            body_limit_bytes,
            max_concurrent,
            cors_origin,
        })?,
        Command::Mcp { db, allow_writes } => {
            let tb = open_toolbox(&db, allow_writes)?;
            errln!(
                "opengraph MCP server on stdio over {} ({})",
                db.display(),
                if allow_writes {
                    "writes allowed"
                } else {
                    "read-only"
                }
            );
            api::mcp::serve_stdio(tb)?;
        }
        Command::Ask {
            db,
            question,
            max_steps,
            llm,
            json,
        } => {
            let mut model = open_llm(&llm.config(llm_tools::LlmConfig::default(), "local"), "ask")?;
            let mut tb = open_toolbox(&db, false)?;
            let a = api::ask::ask(model.as_mut(), &mut tb, &question, max_steps as usize)?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&a)?);
            } else {
                for s in &a.steps {
                    errln!(
                        "tool {}({}){}",
                        s.tool,
                        s.arguments,
                        if s.is_error {
                            format!(" -> error: {}", s.result)
                        } else {
                            String::new()
                        }
                    );
                }
                match (&a.answer, &a.stopped) {
                    (Some(t), _) => outln!("{t}"),
                    (None, Some(why)) => errln!("no answer: {why}"),
                    _ => {}
                }
            }
        }
        Command::Tools { writes } => {
            outln!(
                "{}",
                serde_json::to_string_pretty(&api::tools::tools(writes))?
            );
        }
        Command::Tool {
            db,
            name,
            args,
            writes,
        } => {
            let args: serde_json::Value = serde_json::from_str(&args)
                .map_err(|e| UsageError(format!("the arguments are not JSON: {e}")))?;
            let mut tb = open_toolbox(&db, writes)?;
            match tb.call(&name, &args) {
                Ok(v) => outln!("{}", serde_json::to_string_pretty(&v)?),
                Err(e) if e.exit_code() == 2 => return Err(UsageError(e.to_string()).into()),
                Err(e) => return Err(e.into()),
            }
        }
        Command::Locate {
            db,
            text,
            k,
            parser,
            llm,
            json,
        } => {
            let store = open_read(&db)?;
            let r = store.read()?;
            let parser = parser_of(&parser);
            let mut finder = finder_for(&r, None, parser == api::find::ParserKind::Llm, &llm)?;
            let a = finder.locate(
                &r,
                &api::find::LocateRequest {
                    text,
                    k: k as usize,
                    parser,
                },
            )?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&a)?);
            } else {
                errln!("description: {}", serde_json::to_string(&a.description)?);
                if let Some(m) = &a.parsed_by {
                    errln!("parsed by {m}");
                }
                for (i, l) in a.results.iter().enumerate() {
                    outln!(
                        "{}. segment {} ({}), score {:.3}, position [{:.1}, {:.1}]{}",
                        i + 1,
                        l.segment,
                        l.kind,
                        l.score,
                        l.position[0],
                        l.position[1],
                        match l.kind_match {
                            Some(false) => ", kind differs from the description",
                            _ => "",
                        }
                    );
                    for e in &l.evidence {
                        outln!(
                            "     '{}': node {} {:.1} m from the segment ({})",
                            e.landmark,
                            e.instance_id,
                            e.distance_m,
                            e.caption
                        );
                    }
                }
                errln!(
                    "parse {:.1} ms, rank {:.1} ms",
                    a.timings_ms[0],
                    a.timings_ms[1]
                );
            }
        }
        Command::Query {
            db,
            params,
            json,
            read_only,
            timeout_secs,
            max_rows,
            cypher,
        } => {
            if !(timeout_secs.is_finite() && timeout_secs > 0.0) {
                return Err(UsageError(format!(
                    "--timeout-secs must be positive, got {timeout_secs}"
                ))
                .into());
            }
            let store = open_store(&db, !read_only)?;
            let opts = graphstore::cypher::QueryOptions {
                params: params.into_iter().collect(),
                timeout: Some(std::time::Duration::from_secs_f64(timeout_secs)),
                row_limit: Some(max_rows),
                read_only,
                ..graphstore::cypher::QueryOptions::default()
            };
            let t0 = std::time::Instant::now();
            let r = store.query(&cypher, &opts)?;
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            if let Some(plan) = &r.plan {
                out!("{plan}");
                return Ok(());
            }
            if json {
                outln!("{}", serde_json::to_string_pretty(&r.rows_json())?);
            } else {
                let cells: Vec<Vec<String>> = r
                    .rows
                    .iter()
                    .map(|row| row.iter().map(|v| cell(r.render(v))).collect())
                    .collect();
                let mut width: Vec<usize> = r.columns.iter().map(|c| c.chars().count()).collect();
                for row in &cells {
                    for (w, c) in width.iter_mut().zip(row) {
                        *w = (*w).max(c.chars().count());
                    }
                }
                let line = |vals: &[String]| {
                    let parts: Vec<String> = vals
                        .iter()
                        .zip(&width)
                        .map(|(v, w)| format!("{v}{}", " ".repeat(w - v.chars().count())))
                        .collect();
                    format!("| {} |", parts.join(" | "))
                };
                if !r.columns.is_empty() {
                    outln!("{}", line(&r.columns));
                    let rule: Vec<String> = width.iter().map(|w| "-".repeat(*w)).collect();
                    outln!("{}", line(&rule));
                    for row in &cells {
                        outln!("{}", line(row));
                    }
                }
            }
            let st = r.stats;
            let mut wrote = Vec::new();
            for (n, what) in [
                (st.nodes_created, "nodes created"),
                (st.nodes_deleted, "nodes deleted"),
                (st.relationships_created, "relationships created"),
                (st.relationships_deleted, "relationships deleted"),
                (st.properties_set, "properties set"),
                (st.properties_removed, "properties removed"),
                (st.labels_added, "labels added"),
                (st.labels_removed, "labels removed"),
            ] {
                if n > 0 {
                    wrote.push(format!("{n} {what}"));
                }
            }
            errln!(
                "{} row(s) in {ms:.1} ms{}",
                r.rows.len(),
                if wrote.is_empty() {
                    String::new()
                } else {
                    format!("; {}", wrote.join(", "))
                }
            );
        }
        Command::Oracle { kitti, out, frames } => {
            use ingest::build::{Sequence, Source, key_frames};
            let seq = Sequence::open(&kitti, None)?;
            let list = key_frames(&seq, &Source::Oracle, frames.as_ref(), 1)?;
            std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
            let cfg = ingest::sources::oracle::OracleConfig::default();
            let mut n = 0;
            let image_size = ingest::mapping::MappingConfig::default().image_size;
            for i in &list {
                let scan = ingest::sources::kitti::read_scan(&seq.scan_path(*i))?;
                let cam = seq.camera(*i, image_size)?;
                let d = seq.oracle(*i, &scan, &cam, &cfg)?;
                n += d.detections.len();
                ingest::sources::detections::write_detections(
                    &out.join(format!("{i:06}.json")),
                    &d,
                )?;
            }
            outln!(
                "wrote {} oracle detections for {} frames to {}",
                n,
                list.len(),
                out.display()
            );
        }
        Command::Eval {
            what:
                EvalCommand::Semseg {
                    db,
                    kitti,
                    frames,
                    poses,
                    max_dist_m,
                    json,
                },
        } => {
            let store = open_read(&db)?;
            let r = ingest::eval::eval_semseg(
                &store,
                &kitti,
                poses.as_deref(),
                frames,
                max_dist_m,
                ingest::mapping::MappingConfig::default().image_size,
            )?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&r)?);
            } else {
                outln!(
                    "semseg on {} scans, {} labelled points ({} missed), detections from {}",
                    r.scans,
                    r.points,
                    r.missed,
                    r.source
                );
                outln!("{:<14} {:>7} {:>7} {:>9}", "class", "IoU", "F1", "points");
                for (c, s) in &r.per_class {
                    outln!("{c:<14} {:>7.3} {:>7.3} {:>9}", s.iou, s.f1, s.support);
                }
                outln!("mIoU {:.3}   macro F1 {:.3}", r.miou, r.f1);
                outln!(
                    "in camera view: {} points ({} missed), mIoU {:.3}, macro F1 {:.3}",
                    r.in_view.points,
                    r.in_view.missed,
                    r.in_view.miou,
                    r.in_view.f1
                );
            }
        }
        Command::Eval {
            what: EvalCommand::Relations { db, sim, json },
        } => {
            let store = open_read(&db)?;
            let r = ingest::eval_llm::eval_relations(&store.read()?, &sim)?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&r)?);
            } else {
                outln!(
                    "{} LLM-labelled pairs, {} with a relation that follows from the ground truth; models: {}",
                    r.llm_pairs,
                    r.judged,
                    r.models
                );
                for (name, a) in [("llm", &r.llm), ("geometric", &r.geometric)] {
                    let per: Vec<String> = a
                        .per_truth
                        .iter()
                        .map(|(t, (n, s))| format!("{t} {s:.2} (n={n})"))
                        .collect();
                    outln!(
                        "{name:<10} agreement {:.3} (strict {:.3}) over {} pairs; {}",
                        a.agreement,
                        a.strict_agreement,
                        a.pairs,
                        per.join(", ")
                    );
                }
            }
        }
        Command::Eval {
            what:
                EvalCommand::Retrieval {
                    db,
                    sim,
                    queries,
                    rank,
                    llm,
                    verbose,
                    json,
                },
        } => {
            let qs = ingest::eval_retrieval::read_queries(&queries)?;
            let store = open_read(&db)?;
            let r = store.read()?;
            let ranking = rank.ranking();
            let rerank_n = rank.rerank_n;
            let mut finder = finder_for(&r, None, needs_llm(ranking), &llm)?;
            let mut latencies = Vec::new();
            let report = ingest::eval_retrieval::eval_retrieval(&sim, &qs, |text| {
                let t = std::time::Instant::now();
                let a = finder
                    .find(
                        &r,
                        &api::find::FindRequest {
                            text: text.to_string(),
                            k: 3,
                            class: None,
                            near: None,
                            ranking,
                            rerank_n: rerank_n as usize,
                        },
                    )
                    .map_err(|e| ingest::Error::Invalid(format!("{text:?}: {e}")))?;
                latencies.push(t.elapsed().as_secs_f64() * 1e3);
                Ok(a.results
                    .into_iter()
                    .map(|g| (g.id, g.caption, g.centroid))
                    .collect())
            })?;
            let p50 = median(&mut latencies);
            if json {
                let mut v = serde_json::to_value(&report)?;
                v["p50_ms"] = serde_json::json!(p50);
                outln!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                let how = match ranking {
                    api::find::Ranking::Plain => "plain embedding ranking".to_string(),
                    api::find::Ranking::Graph { parser, rerank } => format!(
                        "graph-aware, {} parser{}",
                        if parser == api::find::ParserKind::Llm {
                            "LLM"
                        } else {
                            "rule"
                        },
                        if rerank { ", LLM re-ranking" } else { "" }
                    ),
                };
                outln!(
                    "retrieval on {} ({how}), p50 {p50:.1} ms per query",
                    queries.display()
                );
                outln!(
                    "{:<12} {:>7} {:>6} {:>6} {:>6}",
                    "type",
                    "queries",
                    "R@1",
                    "R@2",
                    "R@3"
                );
                for t in ingest::eval_retrieval::QUERY_TYPES {
                    if let Some(s) = report.per_type.get(t) {
                        outln!(
                            "{t:<12} {:>7} {:>6.3} {:>6.3} {:>6.3}",
                            s.queries,
                            s.r_at_1,
                            s.r_at_2,
                            s.r_at_3
                        );
                    }
                }
                for u in &report.unanswerable {
                    outln!("not scored (no true object satisfies it): {u}");
                }
                if verbose {
                    for q in &report.queries {
                        outln!(
                            "{} [{}] {:?}",
                            q.first_hit
                                .map_or("MISS".to_string(), |h| format!("hit@{h}")),
                            q.kind,
                            q.text
                        );
                        for (id, cap, under) in &q.returned {
                            outln!(
                                "      {id:>6} {:<18} {cap}",
                                under.as_deref().unwrap_or("(nothing)")
                            );
                        }
                    }
                }
            }
        }
        Command::Eval {
            what:
                EvalCommand::Locate {
                    db,
                    sim,
                    per_spot,
                    seed,
                    parser,
                    llm,
                    verbose,
                    json,
                },
        } => {
            let cases = ingest::eval_locate::generate_cases(&sim, per_spot as usize, seed)?;
            let store = open_read(&db)?;
            let r = store.read()?;
            let parser = parser_of(&parser);
            let mut finder = finder_for(&r, None, parser == api::find::ParserKind::Llm, &llm)?;
            let segments = finder.segments(&r)?.to_vec();
            let mut latencies = Vec::new();
            let report = ingest::eval_locate::eval_locate(&cases, &segments, |text| {
                let t = std::time::Instant::now();
                let a = finder
                    .locate(
                        &r,
                        &api::find::LocateRequest {
                            text: text.to_string(),
                            k: 3,
                            parser,
                        },
                    )
                    .map_err(|e| ingest::Error::Invalid(format!("{text:?}: {e}")))?;
                latencies.push(t.elapsed().as_secs_f64() * 1e3);
                let pos = a.results.first().map(|l| l.position);
                Ok((a.results.into_iter().map(|l| l.segment).collect(), pos))
            })?;
            let p50 = median(&mut latencies);
            if json {
                let mut v = serde_json::to_value(&report)?;
                v["p50_ms"] = serde_json::json!(p50);
                outln!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                outln!(
                    "locate on {} descriptions ({} parser; {} spots in no map segment not scored), p50 {p50:.1} ms",
                    report.all.cases,
                    if parser == api::find::ParserKind::Llm {
                        "LLM"
                    } else {
                        "rule"
                    },
                    report.unmatched
                );
                outln!(
                    "{:<12} {:>6} {:>6} {:>6}",
                    "kind",
                    "cases",
                    "top-1",
                    "top-3"
                );
                for (k, a) in report
                    .per_kind
                    .iter()
                    .chain(std::iter::once((&"all".to_string(), &report.all)))
                {
                    outln!("{k:<12} {:>6} {:>6.3} {:>6.3}", a.cases, a.top1, a.top3);
                }
                if let Some(e) = report.median_position_error_m {
                    outln!("median position error {e:.1} m");
                }
                if verbose {
                    for o in &report.outcomes {
                        outln!(
                            "{} truth {} got {:?}: {}",
                            if o.returned.first() == Some(&o.truth) {
                                "ok  "
                            } else {
                                "MISS"
                            },
                            o.truth,
                            o.returned,
                            o.text
                        );
                    }
                }
            }
        }
        Command::Eval {
            what: EvalCommand::Instances { db, sim, json },
        } => {
            let store = open_read(&db)?;
            let r = ingest::eval_instances::eval_instances(&store.read()?, &sim)?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&r)?);
            } else {
                outln!(
                    "{} instances ({} surface tiles not counted), {} true objects, {} matched (footprint IoU >= {}): precision {:.3}, recall {:.3}",
                    r.instances,
                    r.surface_tiles,
                    r.objects,
                    r.matched,
                    ingest::eval_instances::MATCH_IOU,
                    r.precision,
                    r.recall
                );
                outln!("recall per true class:");
                for (c, k) in &r.recall_per_class {
                    outln!("  {c:<18} {:>4}/{:<4} {:.3}", k.matched, k.total, k.share);
                }
                outln!("precision per map class:");
                for (c, k) in &r.precision_per_class {
                    outln!("  {c:<18} {:>4}/{:<4} {:.3}", k.matched, k.total, k.share);
                }
            }
        }
        Command::Eval {
            what: EvalCommand::Captions { db, sim, json },
        } => {
            let store = open_read(&db)?;
            let r = ingest::eval_llm::eval_captions(&store.read()?, &sim)?;
            if json {
                outln!("{}", serde_json::to_string_pretty(&r)?);
            } else {
                outln!(
                    "{} object instances, {} matched to a ground-truth object; captions by {}",
                    r.object_instances,
                    r.matched,
                    r.caption_source
                );
                let row = |name: &str, c: &ingest::eval_llm::CaptionScores| {
                    outln!(
                        "{name:<8} colour {:.3} (wrong {:.3}, missing {:.3}, n={})  material {:.3} (wrong {:.3}, missing {:.3}, n={})  noun {:.3}  {:.1} words",
                        c.colour.accuracy,
                        c.colour.contradiction,
                        c.colour.missing,
                        c.colour.judged,
                        c.material.accuracy,
                        c.material.contradiction,
                        c.material.missing,
                        c.material.judged,
                        c.noun_accuracy,
                        c.mean_words
                    );
                    anyhow::Ok(())
                };
                row("all", &r.caption)?;
                if let Some(m) = &r.merged {
                    outln!("the {} merged objects, side by side:", m.llm.instances);
                    row("llm", &m.llm)?;
                    row("medoid", &m.medoid)?;
                }
            }
        }
        Command::Init { db, schema } => {
            if db.exists() {
                return Err(UsageError(format!(
                    "{} already exists; init makes a new store (query it with opengraph query --db {})",
                    db.display(),
                    db.display()
                ))
                .into());
            }
            if let Some(parent) = db.parent().filter(|p| !p.as_os_str().is_empty())
                && !parent.is_dir()
            {
                return Err(UsageError(format!(
                    "cannot create {}: the folder {} does not exist",
                    db.display(),
                    parent.display()
                ))
                .into());
            }
            let store = graphstore::Store::create(&db)
                .with_context(|| format!("creating {}", db.display()))?;
            if schema == "opengraph" {
                store.set_schema(graphstore::opengraph_schema())?;
            }
            outln!(
                "created {} (schema: {schema}); try: opengraph query --db {} \"CREATE (p:Place {{name: 'home'}}) RETURN p\"",
                db.display(),
                db.display()
            );
        }
        Command::Demo { db } => {
            if db.exists() {
                return Err(UsageError(format!(
                    "{} already exists; demo writes a new store",
                    db.display()
                ))
                .into());
            }
            let store = graphstore::Store::create(&db)
                .with_context(|| format!("creating {}", db.display()))?;
            demo::build(&store)?;
            out!("{}", info::table(&store)?);
        }
    }
    Ok(())
}

fn sim_summary(r: &ingest::sources::sim::SimReport) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "city: {:.0} m of road; junctions: {}",
        r.road_length_m,
        r.junctions
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        s,
        "objects: {} ({})",
        r.object_count,
        r.objects
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        s,
        "drive: {} poses at 10 Hz over {:.0} m; {} sensor frames, {} LiDAR points, {} detections ({} visible objects missed on purpose)",
        r.poses, r.drive_length_m, r.frames, r.lidar_points, r.detections, r.missed
    );
    let _ = writeln!(
        s,
        "time: scene {:.2} s, sensors {:.1} s; written to {}",
        r.scene_secs,
        r.sensor_secs,
        r.out.display()
    );
    s
}

fn build_summary(r: &ingest::build::BuildReport, rss_mib: Option<f64>) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "key frames: {} ({} this run{}), detections from {}: {} ({} dropped), non-finite points dropped: {}",
        r.frames_total,
        r.frames_run,
        r.resumed_at
            .map(|f| format!(", resumed at frame {f}"))
            .unwrap_or_default(),
        r.source,
        r.detections,
        r.detections_dropped,
        r.nonfinite_points
    );
    let total: usize = r.instances_per_class.values().sum();
    let _ = writeln!(s, "instances: {total}");
    for (c, n) in &r.instances_per_class {
        let _ = writeln!(s, "  {c:<14} {n}");
    }
    let _ = writeln!(
        s,
        "post-processing: {} dropped, {} merged, {} points denoised",
        r.post.dropped.len(),
        r.post.merged.len(),
        r.post.denoised_points
    );
    let stages: Vec<String> = r
        .ms_per_frame
        .iter()
        .map(|(k, v)| format!("{k} {v:.1}"))
        .collect();
    let _ = writeln!(s, "ms per key frame: {}", stages.join(", "));
    if let Some(h) = &r.hierarchy {
        let lanes: Vec<String> = h
            .lane_nodes
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect();
        let _ = writeln!(
            s,
            "hierarchy: lane nodes {}, {} lane edges, {} instances linked to segments",
            lanes.join(", "),
            h.lane_edges,
            h.instances_linked
        );
    }
    if let Some(m) = rss_mib {
        let _ = writeln!(s, "peak RSS: {m:.0} MiB");
    }
    s
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // the reader of our output went away (`| head`): nothing is wrong, stop quietly
        Err(e) if is_closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            errln!("error: {e:#}");
            if is_input_error(&e) {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
