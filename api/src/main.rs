//! The `opengraph` command-line tool.

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
        /// Start: X,Y (ground plane), lane:ID, segment:ID or instance:ID.
        #[arg(long, allow_hyphen_values = true)]
        from: String,
        /// Goal, in the same forms.
        #[arg(long, allow_hyphen_values = true)]
        to: String,
        /// Minimum turning radius of the vehicle.
        #[arg(long, default_value_t = 5.0)]
        turning_radius_m: f64,
        /// Time budget for OMPL; 0 returns the route polyline as a fallback.
        #[arg(long, default_value_t = 200.0)]
        budget_ms: f64,
        /// Half-width of the corridor around the route the path must stay in.
        #[arg(long, default_value_t = 6.0)]
        corridor_m: f64,
        /// Points farther than this from every lane are refused.
        #[arg(long, default_value_t = 15.0)]
        snap_m: f64,
        /// Print `{"route": {...}, "path": {...}}` as JSON.
        #[arg(long)]
        json: bool,
        /// Draw the lane graph, the route and the path.
        #[arg(long)]
        png: Option<PathBuf>,
    },
    /// Build a small hand-made demo graph with the OpenGraph schema (a stand-in until
    /// `sim` exists), then print its summary.
    Demo {
        /// The store file to create (must not exist yet).
        #[arg(long)]
        db: PathBuf,
    },
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
        if let Some(i) = c.downcast_ref::<ingest::Error>() {
            return !matches!(
                i,
                ingest::Error::Render(_) | ingest::Error::Store(graphstore::Error::Storage(_))
            );
        }
        c.downcast_ref::<UsageError>().is_some()
    })
}

/// A problem with the arguments that clap cannot see.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct UsageError(String);

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Info { db, json } => {
            let store = graphstore::Store::open(&db)
                .with_context(|| format!("opening {}", db.display()))?;
            let text = if json {
                info::json(&store)?
            } else {
                info::table(&store)?
            };
            print!("{text}");
        }
        Command::Export {
            db,
            format,
            out,
            edges_key,
        } => {
            let store = graphstore::Store::open(&db)
                .with_context(|| format!("opening {}", db.display()))?;
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
            eprintln!(
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
                println!("{}", serde_json::to_string_pretty(&render::lanes_json(&g))?);
            } else {
                let kinds: Vec<String> = g
                    .kind_counts()
                    .iter()
                    .map(|(k, n)| format!("{} {n}", k.as_str()))
                    .collect();
                println!(
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
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                println!("{report:?}");
            }
        }
        Command::Plan {
            db,
            from,
            to,
            turning_radius_m,
            budget_ms,
            corridor_m,
            snap_m,
            json,
            png,
        } => {
            let store = graphstore::Store::open(&db)
                .with_context(|| format!("opening {}", db.display()))?;
            let r = store.read()?;
            let t0 = std::time::Instant::now();
            let g = planner::RoadGraph::from_store(&r)?;
            let ground = planner::graph::ground_of_store(&r)?;
            let (a, b) = (from.parse::<planner::Spec>()?, to.parse::<planner::Spec>()?);
            let (a, b) = (
                planner::resolve(&g, &r, ground, &a, snap_m)?,
                planner::resolve(&g, &r, ground, &b, snap_m)?,
            );
            let route = planner::astar(&g, a, b)?;
            let t_route = t0.elapsed();
            let cfg = planner::MotionConfig {
                turning_radius_m,
                budget_ms,
                corridor_half_width_m: corridor_m,
                ..planner::MotionConfig::default()
            };
            let obstacles = planner::motion::blocking_instances(&r, ground, &route, corridor_m)?;
            let path = planner::plan_path(&route, &obstacles, &cfg)?;
            let t_all = t0.elapsed();
            if let Some(w) = &path.warning {
                eprintln!("warning: {w}");
            }
            if let Some(p) = &png {
                planner::render::write_png(p, &g, &route, &path, &obstacles)?;
            }
            if json {
                let v = serde_json::json!({
                    "route": {"nodes": route.nodes, "length_m": route.length_m},
                    "path": {"poses": path.poses, "length_m": path.length_m, "planner": path.planner},
                });
                println!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                println!(
                    "route: {} nodes, {:.1} m ({:.1} ms)\npath: {} poses, {:.1} m by {} ({:.1} ms in all, {} blocking boxes)",
                    route.nodes.len(),
                    route.length_m,
                    t_route.as_secs_f64() * 1e3,
                    path.poses.len(),
                    path.length_m,
                    path.planner,
                    t_all.as_secs_f64() * 1e3,
                    obstacles.len()
                );
            }
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
            print!("{}", info::table(&store)?);
        }
    }
    Ok(())
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
        Err(e) => {
            eprintln!("error: {e:#}");
            if is_input_error(&e) {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
