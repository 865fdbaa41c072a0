//! The command line: clap definitions and value parsers.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

use super::common::ranking_of;
pub(crate) use super::values::*;

/// OpenGraph: an open-vocabulary hierarchical 3D scene graph for outdoor environments.
#[derive(Debug, Parser)]
#[command(name = "opengraph", version, about, propagate_version = true)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Debug, Subcommand)]
pub(crate) enum Command {
    /// Print node counts per label and relationship counts per type.
    Info {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// Print `{"nodes": {LABEL: n}, "relationships": {TYPE: n}}` instead of a table.
        #[arg(long)]
        json: bool,
        /// Also check that every index and count agrees with the data and that no
        /// relationship dangles (reads the whole store); exits 1 when a problem is found.
        #[arg(long)]
        check: bool,
    },
    /// Export the whole graph (payloads such as point clouds are left out).
    Export {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// node-link (networkx JSON), graphml, neo4j-csv (a folder for neo4j-admin import),
        /// geojson (ground-plane metres), spark-dsg (Hydra's scene-graph JSON) or ply (points).
        #[arg(long, value_parser = opengraph_service::export::ExportFormat::NAMES)]
        format: String,
        /// Output file (its folder must exist; `-` or /dev/stdout write to stdout); for
        /// neo4j-csv, a folder (made if missing).
        #[arg(long, value_parser = output_file_or_dir)]
        out: PathBuf,
        /// node-link only: key of the edge list; `links` for networkx older than 3.6.
        #[arg(long, default_value = "edges", value_parser = ["edges", "links"])]
        edges_key: String,
        /// ply only: colour points by class or by instance.
        #[arg(long, default_value = "class", value_parser = ["class", "instance"])]
        colour: String,
        /// Print what was written as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Make a new store from the CSV files of Neo4j's bulk importer (`export --format
    /// neo4j-csv` writes them): `opengraph import --db new.og FOLDER`, or name the files as
    /// neo4j-admin does (`--nodes Person=people.csv --relationships KNOWS=knows.csv`). Node
    /// ids are kept when every `:ID` is an integer. A failed import leaves no store behind.
    Import {
        /// The store file to create (must not exist yet).
        #[arg(long)]
        db: PathBuf,
        /// A folder of nodes*.csv and relationships*.csv files.
        folder: Option<PathBuf>,
        /// A node file, `file.csv` or `Label1:Label2=file.csv` (repeatable).
        #[arg(long)]
        nodes: Vec<String>,
        /// A relationship file, `file.csv` or `TYPE=file.csv` (repeatable).
        #[arg(long)]
        relationships: Vec<String>,
        /// A networkx node-link JSON file instead of CSV (`export --format node-link` writes one).
        #[arg(long, conflicts_with_all = ["folder", "nodes", "relationships"])]
        node_link: Option<PathBuf>,
        /// The relationship type of node-link edges without a `type`.
        #[arg(long, default_value = "RELATED_TO")]
        default_type: String,
        /// `none` (schema-free) or `opengraph` (the map schema, for an exported map).
        #[arg(long, default_value = "none", value_parser = ["none", "opengraph"])]
        schema: String,
        /// Rows per committed transaction.
        #[arg(long, default_value_t = 100_000, value_parser = clap::value_parser!(u32).range(1..))]
        batch_rows: u32,
        /// Print what was imported as JSON.
        #[arg(long)]
        json: bool,
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
        #[arg(long, value_parser = output_file)]
        out: PathBuf,
        /// Bird's-eye PNG: trajectory, lane edges, nodes coloured by kind, segment areas.
        #[arg(long, value_parser = output_file)]
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
    /// Route over the store's lane graph (A*) and refine it into a drivable path with OMPL;
    /// or over an Argoverse 2 HD map with --av2-map.
    Plan {
        /// The store file.
        #[arg(long, required_unless_present = "av2_map", conflicts_with = "av2_map")]
        db: Option<PathBuf>,
        /// Plan over an Argoverse 2 HD map (`log_map_archive_*.json`) instead of a store:
        /// --from and --to are then X,Y in the map's city frame (metres).
        #[arg(long)]
        av2_map: Option<PathBuf>,
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
        /// Key frames A..B (half-open): the scans the sequence has in the range; default: every
        /// frame with a scan and detections/labels.
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
        #[arg(long, value_parser = output_dir)]
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
        #[arg(long, value_parser = output_dir)]
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
        /// Probability that a visible object is not detected (0..1).
        #[arg(long, default_value_t = 0.05, value_parser = in_range(0.0, 1.0), allow_hyphen_values = true)]
        miss_rate: f64,
        /// Mean false-positive detections per frame (0..50).
        #[arg(long, default_value_t = 0.2, value_parser = in_range(0.0, 50.0), allow_hyphen_values = true)]
        false_positives: f64,
        /// Probability of a caption phrased differently from the ground truth (0..1).
        #[arg(long, default_value_t = 0.5, value_parser = in_range(0.0, 1.0), allow_hyphen_values = true)]
        paraphrase_rate: f64,
        /// Probability of a caption with a wrong colour (0..1).
        #[arg(long, default_value_t = 0.05, value_parser = in_range(0.0, 1.0), allow_hyphen_values = true)]
        wrong_attribute_rate: f64,
        /// Masks are eroded or dilated by up to this many pixels.
        #[arg(long, default_value_t = 1)]
        mask_noise_px: u32,
        /// No detection noise at all (overrides the five options above).
        #[arg(long)]
        no_noise: bool,
        /// Cars driving to and fro along the roads (their LiDAR points are labelled
        /// moving-car, 252), 0..5000.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=5000))]
        moving_cars: u32,
        /// People walking to and fro along the sidewalks (moving-person, 254), 0..5000.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=5000))]
        walkers: u32,
        /// Worker threads (the output does not depend on it); default: all cores.
        #[arg(long)]
        threads: Option<usize>,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Experimental, not a feature: label relations between close objects with a language
    /// model (the paper's LLM relation inference): RELATED {source: "llm", relation,
    /// confidence, model, prompt} beside the geometric edges, which `find` and the tools use
    /// instead. The local models agree with the simulator's relations less often than the
    /// geometric labels (docs/llm.md), so it runs only with --experimental. Resumable: pairs
    /// already labelled by the same model and prompt are skipped, and every answer is cached.
    Relations {
        /// The store file.
        #[arg(long)]
        db: PathBuf,
        /// Run it although it is an experiment whose labels are worse than the map's own.
        #[arg(long)]
        experimental: bool,
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
        /// Print a JSON array of results: {"id", "label", "caption", "semantic_class", "score", "centroid",
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
        /// Print the answer as JSON: {"description": {"segment", "landmarks", "beside"},
        /// "parsed_by", "results": [{"segment", "kind", "score", "kind_match", "position",
        /// "position_uncertainty_m", "evidence"}], "unmatched", "timings_ms": [parse, rank]}.
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
        /// Who reads the description: rules, or the language model (prompt parse_edit@v1).
        #[arg(long, value_parser = ["rules", "llm"], default_value = "rules")]
        parser: String,
        #[command(flatten)]
        llm: LlmArgs,
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
        /// A file holding the write token (16 characters or more); or put the token in the
        /// OPENGRAPH_TOKEN environment variable (not both). Without one the server is
        /// read-only; a non-loopback --bind needs one.
        #[arg(long)]
        token_file: Option<PathBuf>,
        /// Refuse writes even with a token (the store is opened read-only).
        #[arg(long)]
        read_only: bool,
        /// Read requests served side by side (each worker holds a sentence embedder, ~100 MB);
        /// default: the number of cores, at most 8. With writes on, one more worker runs the
        /// writes alone, so a commit never holds up a reader.
        #[arg(long)]
        workers: Option<usize>,
        /// Seconds a request may wait and run (0.1..3600).
        #[arg(long, default_value_t = 30.0, value_parser = in_range(0.1, 3600.0), allow_hyphen_values = true)]
        timeout_secs: f64,
        /// The largest request body in bytes.
        #[arg(long, default_value_t = 1 << 20)]
        body_limit_bytes: usize,
        /// Requests in progress at once; more get 503.
        #[arg(long, default_value_t = 64)]
        max_concurrent: usize,
        /// Request texts whose sentence embeddings are kept for reuse, shared by the workers
        /// (least recently used out; 4,096 MiniLM vectors take about 6 MiB; 0 turns it off).
        #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(0..=1_000_000))]
        embedding_cache: u32,
        /// Answers of read-only Cypher statements kept for reuse until the next write, shared
        /// by the workers (least recently used out; answers over 1,000 rows and statements
        /// calling rand() are never kept; 0 turns it off).
        #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(0..=100_000))]
        query_cache: u32,
        /// A browser origin allowed to call the API (CORS); repeat for more. Default: CORS off.
        #[arg(long)]
        cors_origin: Vec<String>,
        /// A `Host` name the server answers to besides localhost, 127.0.0.1, [::1] and the bind
        /// address (behind a proxy or a DNS name); repeat for more. Requests with any other
        /// Host get 403, on every route (a DNS-rebinding page cannot read the map).
        #[arg(long)]
        allowed_host: Vec<String>,
        /// Seconds a client has to send a request's headers (and to start its next request on
        /// a kept-alive connection), and again its body; slower connections are closed.
        #[arg(long, default_value_t = 10.0, value_parser = in_range(0.1, 3600.0), allow_hyphen_values = true)]
        client_timeout_secs: f64,
        /// Open connections at most; more are answered 503 and closed.
        #[arg(long, default_value_t = 1024)]
        max_connections: usize,
        /// Open connections from one client address at most.
        #[arg(long, default_value_t = 256)]
        max_connections_per_client: usize,
        /// A language model for POST /api/ask (default: none).
        #[command(flatten)]
        llm: LlmArgs,
        #[command(flatten)]
        zenoh: ZenohArgs,
    },
    /// Publish a KITTI-layout sequence (scans, poses, calibration, detections) as ROS 2
    /// messages on rmw_zenoh keys at a chosen rate, for `serve --zenoh` or any ROS 2 node on
    /// rmw_zenoh (docs/live.md).
    Replay {
        /// The sequence directory (velodyne/, poses.txt, calib.txt; times.txt and image_2/
        /// when present).
        #[arg(long)]
        kitti: PathBuf,
        /// The detections directory (default: <kitti>/detections).
        #[arg(long)]
        detections: Option<PathBuf>,
        /// Poses A..B (half-open frame numbers); default: all.
        #[arg(long, value_parser = parse_range)]
        frames: Option<std::ops::Range<u32>>,
        /// Speed: 1 is real time (times.txt, or 10 Hz), 2 twice as fast, 0 as fast as zenoh
        /// takes it.
        #[arg(long, default_value_t = 1.0, value_parser = in_range(0.0, 1000.0), allow_hyphen_values = true)]
        rate: f64,
        /// A build configuration whose [live] table gives the topics, domain and frames.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Seconds to wait for a subscriber to the clouds before publishing.
        #[arg(long, default_value_t = 10.0, value_parser = in_range(0.0, 3600.0), allow_hyphen_values = true)]
        wait_secs: f64,
        #[command(flatten)]
        session: ZenohSession,
        /// Print what was published as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Cut a map into region shards: one store per region (r1.og, r2.og, ...; node ids kept)
    /// to serve on several servers with `serve --zenoh --no-live --map-name M --region rN`,
    /// asked together with `opengraph zenoh-query` (docs/live.md).
    Shard {
        /// The map's store.
        #[arg(long)]
        db: PathBuf,
        /// How many regions (cut across the map's longer side, about as many road segments
        /// in each).
        #[arg(long, default_value_t = 3)]
        parts: usize,
        /// The folder for the regions' stores (made if missing; existing stores are not
        /// overwritten).
        #[arg(long)]
        out: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Ask a sharded map served over zenoh: a read-only tool fanned out over its regions
    /// (opengraph/<map>/*/query) and the answers merged: find_objects and locate give the
    /// global top k, read_cypher the union of the rows with their region; a region that does
    /// not answer is reported missing. Prints JSON.
    ZenohQuery {
        /// The map's name in keys.
        #[arg(long)]
        map: String,
        /// A read-only tool (find_objects, locate, read_cypher, describe_area, ...).
        tool: String,
        /// Its arguments as a JSON object.
        #[arg(default_value = "{}")]
        args: String,
        /// The regions expected, comma-separated (one that does not answer is missing);
        /// default: those whose liveliness token is seen.
        #[arg(long, value_delimiter = ',')]
        regions: Vec<String>,
        /// Seconds each pass waits for the regions' replies.
        #[arg(long, default_value_t = 5.0, value_parser = in_range(0.01, 3600.0), allow_hyphen_values = true)]
        deadline_secs: f64,
        #[command(flatten)]
        session: ZenohSession,
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
        /// The blind baseline for evaluations: the model answers without the map's tools
        /// (it cannot see the map). Needs --llm local or openai.
        #[arg(long)]
        blind: bool,
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
        /// Stop the statement after this many seconds (a write is rolled back; 0.001..86400).
        #[arg(long, default_value_t = 30.0, value_parser = in_range(0.001, 86400.0), allow_hyphen_values = true)]
        timeout_secs: f64,
        /// Fail when the result has more rows than this (add LIMIT).
        #[arg(long, default_value_t = 100_000, value_parser = clap::value_parser!(u64).range(1..))]
        max_rows: u64,
        /// Run a read-only statement this many more times after the first, and print the
        /// engine time's p50 and p99 over those runs to stderr (for benchmarks).
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=100_000))]
        repeat: u32,
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
pub(crate) enum EvalCommand {
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
    /// the query's predicate. Queries: JSON Lines (see ingest/eval/data/retrieval_small_city.jsonl).
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
    /// Road areas against the simulator's roads (carriageways and parking lanes): per segment,
    /// the area IoU of its trajectory disc or corridor ("before") and of its drivable polygon
    /// measured from the map ("after") with the true drivable ground that belongs to it.
    Roads {
        /// The store file (built from the simulator's detections).
        #[arg(long)]
        db: PathBuf,
        /// The simulator's output folder (with ground_truth/roads.json).
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
        /// A labelled point takes the class of the nearest map point within this radius
        /// (0.01..10 m).
        #[arg(long, default_value_t = 0.3, value_parser = in_range(0.01, 10.0), allow_hyphen_values = true)]
        max_dist_m: f64,
        /// Print `{"miou", "f1", "per_class", "source", ...}`.
        #[arg(long)]
        json: bool,
    },
}

/// How `find` and `eval retrieval` rank.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct RankArgs {
    /// Rank by the cosine of the whole text with each instance's feature only (no parsing,
    /// no graph).
    #[arg(long, conflicts_with_all = ["parser", "rerank"])]
    pub(crate) plain: bool,
    /// Who parses the request: the rule parser or the language model.
    #[arg(long, value_parser = ["rules", "llm"], default_value = "rules")]
    pub(crate) parser: String,
    /// Re-rank with a language model (OpenGraph-LLM): it picks the best three of the first
    /// --rerank-n results.
    #[arg(long, value_parser = ["llm"])]
    pub(crate) rerank: Option<String>,
    /// Results shown to the re-ranking model.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(2..=30))]
    pub(crate) rerank_n: u64,
}

impl RankArgs {
    pub(crate) fn ranking(&self) -> api::find::Ranking {
        ranking_of(self.plain, &self.parser, self.rerank.is_some())
    }
}

/// Planner settings shared by `plan` and `navigate`; each is checked (finite, in range)
/// before any work.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct PlanArgs {
    /// Minimum turning radius of the vehicle, metres, in [0.5, 100].
    #[arg(long, default_value_t = api::plan::PlanOptions::DEFAULT.turning_radius_m, value_parser = in_range(0.5, 100.0), allow_hyphen_values = true)]
    pub(crate) turning_radius_m: f64,
    /// Time budget for OMPL, milliseconds, in [0, 60000]; 0 returns the route polyline as a
    /// fallback.
    #[arg(long, default_value_t = api::plan::PlanOptions::DEFAULT.budget_ms, value_parser = in_range(0.0, 60000.0), allow_hyphen_values = true)]
    pub(crate) budget_ms: f64,
    /// Half-width of the corridor around the route the path must stay in, metres, in
    /// [0.5, 100].
    #[arg(long, default_value_t = api::plan::PlanOptions::DEFAULT.corridor_m, value_parser = in_range(0.5, 100.0), allow_hyphen_values = true)]
    pub(crate) corridor_m: f64,
    /// Points farther than this from every lane are refused, metres, in [0, 1000].
    #[arg(long, default_value_t = api::plan::PlanOptions::DEFAULT.snap_m, value_parser = in_range(0.0, 1000.0), allow_hyphen_values = true)]
    pub(crate) snap_m: f64,
    /// Draw the map (instances in SemanticKITTI class colours), the lane graph, the route
    /// (blue), the path, the boxes that block it, the start (green) and the goal (red).
    #[arg(long, value_parser = output_file)]
    pub(crate) png: Option<PathBuf>,
}

impl PlanArgs {
    pub(crate) fn options(&self) -> api::plan::PlanOptions {
        api::plan::PlanOptions {
            turning_radius_m: self.turning_radius_m,
            budget_ms: self.budget_ms,
            corridor_m: self.corridor_m,
            snap_m: self.snap_m,
            png: self.png.clone(),
        }
    }
}

/// How to join zenoh: a configuration file, or endpoints (a peer with multicast scouting
/// off). Default: `serve` listens on tcp/127.0.0.1:7447 and `replay` connects there.
#[derive(clap::Args, Debug, Clone, Default)]
pub(crate) struct ZenohSession {
    /// A zenoh JSON5 configuration file (mode, endpoints, scouting), used as it is.
    #[arg(long)]
    pub(crate) zenoh_config: Option<PathBuf>,
    /// An endpoint to listen on, e.g. tcp/127.0.0.1:7447; repeatable.
    #[arg(long)]
    pub(crate) zenoh_listen: Vec<String>,
    /// An endpoint to connect to (a router or a peer), e.g. tcp/127.0.0.1:7447; repeatable.
    #[arg(long)]
    pub(crate) zenoh_connect: Vec<String>,
}

impl ZenohSession {
    pub(crate) fn options(&self) -> og_zenoh::SessionOptions {
        og_zenoh::SessionOptions {
            config_file: self.zenoh_config.clone(),
            listen: self.zenoh_listen.clone(),
            connect: self.zenoh_connect.clone(),
        }
    }

    /// Opens a client's session: as given, or connected to a server on this machine at the
    /// default listener when nothing is given. A bad configuration is the user's error.
    pub(crate) fn open_client(&self) -> anyhow::Result<zenoh::Session> {
        let mut opts = self.options();
        if opts.config_file.is_none() && opts.listen.is_empty() && opts.connect.is_empty() {
            opts.connect = vec![og_zenoh::DEFAULT_LISTEN.to_string()];
        }
        opts.open().map_err(|e| match e {
            og_zenoh::Error::Config(m) => anyhow::Error::from(super::common::UsageError(m)),
            other => other.into(),
        })
    }
}

/// `serve --zenoh`: the map over zenoh, and live ingest from ROS 2 topics.
#[derive(clap::Args, Debug, Clone, Default)]
pub(crate) struct ZenohArgs {
    /// Serve over zenoh too: events, read-only queries, the whole graph and status under
    /// opengraph/<map>[/<region>]; and map live from the ROS 2 topics of [live] (unless
    /// --no-live). The store is created when missing (docs/live.md).
    #[arg(long)]
    pub(crate) zenoh: bool,
    #[command(flatten)]
    pub(crate) session: ZenohSession,
    /// Serve over zenoh without live ingest (a map built in batch, a region shard).
    #[arg(long, requires = "zenoh")]
    pub(crate) no_live: bool,
    /// The map's name in zenoh keys (default: the store file's name without its extension).
    #[arg(long, requires = "zenoh")]
    pub(crate) map_name: Option<String>,
    /// The region of a sharded map this server holds: its keys are
    /// opengraph/<map>/<region>/..., and `opengraph zenoh-query` fans out over the regions.
    #[arg(long, requires = "zenoh")]
    pub(crate) region: Option<String>,
    /// A build configuration (TOML: [mapping], [dynamic], [hierarchy], [live]).
    #[arg(long, requires = "zenoh")]
    pub(crate) config: Option<PathBuf>,
    /// A KITTI calib.txt whose Tr is the LiDAR-to-camera calibration ([live] cam_from_velo).
    #[arg(long, requires = "zenoh")]
    pub(crate) calib: Option<PathBuf>,
    /// Sentence embedder for live captions: minilm or hash.
    #[arg(long, default_value = "minilm", value_parser = ["minilm", "hash"], requires = "zenoh")]
    pub(crate) embedder: String,
}

/// Which language model to use: the same three flags on every command that needs one.
#[derive(clap::Args, Debug, Clone, Default)]
pub(crate) struct LlmArgs {
    /// Language model: local (llama.cpp on a GGUF file), openai (an OpenAI-compatible server:
    /// OPENAI_BASE_URL, OPENAI_MODEL, OPENAI_API_KEY) or none.
    #[arg(long, value_parser = ["local", "openai", "none"])]
    pub(crate) llm: Option<String>,
    /// For local: the GGUF file (default: the default model that scripts/setup.sh fetched);
    /// for openai: the model name.
    #[arg(long)]
    pub(crate) llm_model: Option<String>,
    /// For openai: the server's base URL, e.g. http://127.0.0.1:8080/v1.
    #[arg(long)]
    pub(crate) llm_url: Option<String>,
}

impl LlmArgs {
    /// The flags laid over `base` (the `[llm]` table of a config, or the default).
    pub(crate) fn config(
        &self,
        base: llm_tools::LlmConfig,
        default_backend: &str,
    ) -> llm_tools::LlmConfig {
        self.choice().over(base, default_backend)
    }

    /// The flags as the service's choice of model.
    pub(crate) fn choice(&self) -> opengraph_service::build::LlmChoice {
        opengraph_service::build::LlmChoice {
            backend: self.llm.clone(),
            model: self.llm_model.clone(),
            url: self.llm_url.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;
    use clap::error::ErrorKind;

    /// Every leaf command with its path of subcommand names.
    fn leaves(cmd: &clap::Command, path: Vec<String>, out: &mut Vec<(Vec<String>, clap::Command)>) {
        let subs: Vec<&clap::Command> = cmd.get_subcommands().collect();
        if subs.is_empty() {
            out.push((path.clone(), cmd.clone()));
        }
        for s in subs {
            let mut p = path.clone();
            p.push(s.get_name().to_string());
            leaves(s, p, out);
        }
    }

    /// Whether parsing `opengraph PATH --flag VALUE` fails because of this flag's value (before
    /// any other check: clap reports value errors before missing required arguments).
    fn refused(path: &[String], flag: &str, value: &str) -> Option<String> {
        let mut argv = vec!["opengraph".to_string()];
        argv.extend(path.iter().cloned());
        argv.push(flag.to_string());
        argv.push(value.to_string());
        match Cli::try_parse_from(&argv) {
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::ValueValidation
                        | ErrorKind::InvalidValue
                        | ErrorKind::UnknownArgument
                ) =>
            {
                Some(e.to_string())
            }
            _ => None,
        }
    }

    /// Every numeric flag of every command refuses NaN, infinities, negative numbers and absurd
    /// magnitudes at parse time, before any work (issue 17 §3), and names the flag or the value.
    #[test]
    fn every_numeric_flag_refuses_nan_inf_negative_and_huge() {
        let mut all = Vec::new();
        leaves(&Cli::command(), Vec::new(), &mut all);
        let mut numeric = 0;
        let mut bad = Vec::new();
        for (path, cmd) in &all {
            for arg in cmd.get_arguments() {
                let Some(long) = arg.get_long() else { continue };
                if !arg.get_action().takes_values() {
                    continue;
                }
                let flag = format!("--{long}");
                // numeric: letters are refused, and some plain number is taken
                let takes_a_number = ["1", "5", "10", "100"]
                    .iter()
                    .any(|v| refused(path, &flag, v).is_none());
                if refused(path, &flag, "abc").is_none() || !takes_a_number {
                    continue;
                }
                numeric += 1;
                for v in ["nan", "NaN", "inf", "-inf", "-1", "-0.5", "1e308", "1e999"] {
                    if refused(path, &flag, v).is_none() {
                        bad.push(format!("opengraph {} {flag} {v}", path.join(" ")));
                    }
                }
            }
        }
        eprintln!("{numeric} numeric flags checked");
        assert!(numeric >= 25, "found only {numeric} numeric flags");
        assert!(bad.is_empty(), "accepted:\n{}", bad.join("\n"));
    }

    /// Fuzz target `cli_args` (`og-fuzz`; `OG_FUZZ_SECS=600` for ten minutes): argument lists
    /// built from every command and flag, mutated, then parsed; parsing answers a command or a
    /// usage error, never a panic. Arguments are NUL-separated in the fuzzed bytes.
    #[test]
    fn fuzz_cli_args() {
        let mut all = Vec::new();
        leaves(&Cli::command(), Vec::new(), &mut all);
        let mut seeds: Vec<Vec<u8>> = Vec::new();
        for (path, cmd) in &all {
            let mut argv: Vec<String> = path.clone();
            for a in cmd.get_arguments() {
                if let Some(l) = a.get_long() {
                    argv.push(format!("--{l}"));
                    if a.get_num_args().is_some_and(|n| n.takes_values()) {
                        argv.push(
                            a.get_default_values()
                                .first()
                                .map_or("1".to_string(), |v| v.to_string_lossy().to_string()),
                        );
                    }
                } else if a.is_positional() {
                    argv.push("the bench near the bus stop".into());
                }
            }
            seeds.push(argv.join("\0").into_bytes());
        }
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions");
        og_fuzz::fuzz("cli_args", &seeds, &dir, |bytes| {
            let mut argv = vec!["opengraph".to_string()];
            argv.extend(
                String::from_utf8_lossy(bytes)
                    .split('\0')
                    .map(str::to_string),
            );
            let _ = Cli::try_parse_from(&argv);
        });
    }
}
