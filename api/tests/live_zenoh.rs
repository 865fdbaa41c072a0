//! Live ingest over zenoh, end to end, on loopback with real zenoh sessions (multicast
//! scouting off, explicit endpoints): `opengraph replay` publishes a simulated drive as ROS 2
//! messages on rmw_zenoh keys, `opengraph serve --zenoh` maps it while serving, and the
//! result is compared with a batch `build` of the same frames. Also: a server killed with
//! SIGKILL mid-stream resumes without losing a committed frame; malformed samples are
//! counted and ignored; the events stream and the query, graph and status queryables.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::*;
use serde_json::{Value as Json, json};
use zenoh::Wait;

/// `opengraph serve --zenoh` on `port`, its stderr in `log`.
fn live_server(db: &Path, port: u16, sim: &Path, cfg: &Path, log: &Path, extra: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .args(["serve", "--db", s(db), "--bind", "127.0.0.1:0", "--zenoh"])
        .args(["--zenoh-listen", &format!("tcp/127.0.0.1:{port}")])
        .args(["--calib", s(&sim.join("calib.txt"))])
        .args([
            "--config",
            s(cfg),
            "--embedder",
            "hash",
            "--map-name",
            "live",
        ])
        .args(extra)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap()
}

/// A client session connected to the server on `port`.
fn client(port: u16) -> zenoh::Session {
    og_zenoh::SessionOptions::peer(&[], &[format!("tcp/127.0.0.1:{port}")])
        .open()
        .unwrap()
}

/// One reply of `key` (a queryable), as JSON; `None` when nothing answers in 5 s.
fn get(z: &zenoh::Session, key: &str, payload: Option<Json>) -> Option<Result<Json, Json>> {
    let mut g = z.get(key).timeout(Duration::from_secs(5));
    if let Some(p) = payload {
        g = g.payload(p.to_string());
    }
    let replies = g.wait().ok()?;
    let reply = replies
        .recv_timeout(Duration::from_secs(6))
        .ok()
        .flatten()?;
    Some(match reply.result() {
        Ok(sample) => Ok(serde_json::from_slice(&sample.payload().to_bytes()).unwrap()),
        Err(e) => Err(serde_json::from_slice(&e.payload().to_bytes()).unwrap()),
    })
}

/// The live server's `read_cypher` answer for its instance count, over zenoh.
fn count_instances(z: &zenoh::Session) -> Json {
    get(
        z,
        "opengraph/live/query",
        Some(json!({"tool": "read_cypher", "args": {"query": "MATCH (i:Instance) RETURN count(i) AS n"}})),
    )
    .unwrap()
    .unwrap()
}

/// Waits (`secs` at most) until the server's status satisfies `done`; returns the status.
fn wait_status(z: &zenoh::Session, secs: u64, log: &Path, done: impl Fn(&Json) -> bool) -> Json {
    let start = Instant::now();
    loop {
        if let Some(Ok(st)) = get(z, "opengraph/live/status", None)
            && done(&st)
        {
            return st;
        }
        assert!(
            start.elapsed() < Duration::from_secs(secs),
            "the server did not get there within {secs} s; log:\n{}",
            std::fs::read_to_string(log).unwrap_or_default()
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn replay(sim: &Path, port: u16, extra: &[&str]) -> Json {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_opengraph"));
    cmd.args(["replay", "--kitti", s(sim), "--json", "--wait-secs", "30"])
        .args(["--zenoh-connect", &format!("tcp/127.0.0.1:{port}")])
        .args(extra);
    json_of_run(cmd, 600)
}

/// SIGTERM, then waits for the process (it finishes the live map first).
fn stop(mut child: Child, log: &Path) {
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let start = Instant::now();
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            assert!(
                st.success(),
                "the server exited with {st:?}; log:\n{}",
                std::fs::read_to_string(log).unwrap_or_default()
            );
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "the server did not stop"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// What two maps are compared on: instances per class, frames, lane nodes and lanes, segment
/// kinds, and each instance's feature by its first frame and point count.
fn summary(db: &Path) -> Json {
    let q = |c: &str| read_query(db, c);
    json!({
        "classes": q("MATCH (i:Instance) RETURN i.semantic_class AS class, count(*) AS n ORDER BY class"),
        "frames": q("MATCH (f:Frame) RETURN count(*) AS n")[0]["n"],
        "lane_nodes": q("MATCH (l:LaneNode) RETURN count(*) AS n")[0]["n"],
        "lanes": q("MATCH (:LaneNode)-[r:LANE]->(:LaneNode) RETURN count(r) AS n")[0]["n"],
        "segments": q("MATCH (s:Segment) RETURN s.kind AS kind, count(*) AS n ORDER BY kind"),
    })
}

/// A `[live]` table: the map is finished after `idle_secs` without frames.
fn config(dir: &Path, idle_secs: f64) -> PathBuf {
    let cfg = dir.join("live.toml");
    std::fs::write(
        &cfg,
        format!("[live]\nidle_finish_secs = {idle_secs}\nqueue_frames = 1024\nhierarchy_period_secs = 2.0\nmax_wait_secs = 5.0\n"),
    )
    .unwrap();
    cfg
}

/// The sorted features of every instance (with its point count), for a tolerance check.
fn features(db: &Path) -> Vec<(i64, Vec<f64>)> {
    let rows = read_query(
        db,
        "MATCH (i:Instance) RETURN i.point_count AS n, i.feature AS f ORDER BY n, i.caption",
    );
    rows.as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["n"].as_i64().unwrap_or(0),
                r["f"]
                    .as_array()
                    .map(|v| v.iter().map(|x| x.as_f64().unwrap()).collect())
                    .unwrap_or_default(),
            )
        })
        .collect()
}

#[test]
fn a_replayed_drive_mapped_live_matches_the_batch_build() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    json(&og(&["sim", "--out", s(&sim), "--frames", "30", "--json"]));
    let batch = dir.path().join("batch.og");
    build_map(&sim, &batch, &["--embedder", "hash"]);
    let live = dir.path().join("live.og");
    let log = dir.path().join("serve.log");
    let port = free_port();
    let server = live_server(&live, port, &sim, &config(dir.path(), 2.0), &log, &[]);
    let z = client(port);
    // the events stream, from before the first frame
    let events = z
        .declare_subscriber("opengraph/live/events")
        .with(flume_bounded())
        .wait()
        .unwrap();
    // A declaration travels ahead of a query on the same link, so once the server has
    // answered one, it knows the subscriber and the first event reaches it.
    wait_status(&z, 60, &log, |_| true);
    let rep = replay(&sim, port, &["--rate", "0"]);
    assert_eq!(rep["clouds"], 30, "{rep}");
    let st = wait_status(&z, 300, &log, |st| {
        st["live"]["frames_mapped"] == 30 && st["live"]["hierarchy_refreshes"].as_u64() > Some(0)
    });
    let l = &st["live"];
    // the service's info (what HTTP /api/info and MCP answer) carries the same counts
    assert_eq!(st["info"]["live"]["frames_assembled"], 30, "{st}");
    assert!(st["info"]["live"]["commits"].as_u64() > Some(0), "{st}");
    assert_eq!(l["malformed"], json!({}), "{st}");
    assert_eq!(l["dropped_behind"], 0, "{st}");
    assert_eq!(l["incomplete"], json!({}), "{st}");
    // read-only Cypher, find and the graph over zenoh while the server runs
    let n = count_instances(&z);
    assert!(n.to_string().contains("\"n\""), "{n}");
    let found = get(
        &z,
        "opengraph/live/query",
        Some(json!({"tool": "find_objects", "args": {"text": "a car", "k": 3}})),
    )
    .unwrap()
    .unwrap();
    assert!(!found["results"].as_array().unwrap().is_empty(), "{found}");
    let refused = get(
        &z,
        "opengraph/live/query",
        Some(json!({"tool": "write_cypher", "args": {"query": "CREATE (:X)"}})),
    )
    .unwrap()
    .unwrap_err();
    assert_eq!(refused["error"]["code"], "bad_request", "{refused}");
    let graph = get(&z, "opengraph/live/graph", None).unwrap().unwrap();
    assert!(
        graph["nodes"].as_array().unwrap().len() > 30,
        "a node-link graph"
    );
    // events: consecutive numbers, instances added, a hierarchy refresh
    let mut seen = Vec::new();
    while let Ok(Some(s)) = events.try_recv() {
        seen.push(serde_json::from_slice::<Json>(&s.payload().to_bytes()).unwrap());
    }
    assert!(!seen.is_empty());
    assert_eq!(seen[0]["seq"], 1, "the first event: {}", seen[0]);
    for (i, e) in seen.iter().enumerate() {
        assert_eq!(e["seq"], i as u64 + 1, "{e}");
    }
    assert!(seen.iter().any(|e| e["kind"] == "instance_added"));
    assert!(seen.iter().any(|e| e["kind"] == "hierarchy_refreshed"));
    drop(events);
    z.close().wait().unwrap();
    stop(server, &log);
    // progress in the log: a line per commit and per hierarchy refresh
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(
        text.contains("committed") && text.contains("frames mapped of"),
        "no commit lines in the log:\n{text}"
    );
    assert!(
        text.contains("hierarchy refreshed in"),
        "no refresh lines:\n{text}"
    );
    // the live map is the batch map
    let (a, b) = (summary(&batch), summary(&live));
    assert_eq!(a, b, "batch vs live");
    let (fa, fb) = (features(&batch), features(&live));
    assert_eq!(fa.len(), fb.len());
    let mut worst = 0.0f64;
    for ((na, va), (nb, vb)) in fa.iter().zip(&fb) {
        assert_eq!(na, nb, "point counts");
        for (x, y) in va.iter().zip(vb) {
            worst = worst.max((x - y).abs());
        }
    }
    assert!(worst < 1e-5, "features differ by up to {worst}");
}

fn flume_bounded() -> zenoh::handlers::FifoChannel {
    zenoh::handlers::FifoChannel::new(100_000)
}

#[test]
fn a_server_killed_mid_stream_resumes_without_losing_a_committed_frame() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    json(&og(&["sim", "--out", s(&sim), "--frames", "24", "--json"]));
    let live = dir.path().join("live.og");
    // no finish while the drive goes on (a finish post-processes the map so far, and the
    // frames after it build on that): the replay below pauses 3 s between scans
    let cfg = config(dir.path(), 60.0);
    let log = dir.path().join("serve.log");
    let port = free_port();
    let mut server = live_server(&live, port, &sim, &cfg, &log, &[]);
    let z = client(port);
    // replay in the background; kill the server once some frames are committed
    let sim2 = sim.clone();
    let replaying = std::thread::spawn(move || {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_opengraph"));
        cmd.args([
            "replay",
            "--kitti",
            s(&sim2),
            "--rate",
            "4",
            "--wait-secs",
            "30",
        ])
        .args(["--zenoh-connect", &format!("tcp/127.0.0.1:{port}")]);
        output_within(cmd, 600)
    });
    let st = wait_status(&z, 300, &log, |st| {
        st["live"]["commits"].as_u64() >= Some(1)
    });
    let committed_before = st["live"]["frames_mapped"].as_u64().unwrap();
    server.kill().unwrap();
    server.wait().unwrap();
    let _ = replaying.join();
    let frames_then = read_query(&live, "MATCH (f:Frame) RETURN count(*) AS n")[0]["n"]
        .as_u64()
        .unwrap();
    assert!(
        (1..24).contains(&frames_then),
        "{frames_then} frames committed ({committed_before} mapped)"
    );
    // restart, replay the whole drive again: what is in the map is skipped
    let log2 = dir.path().join("serve2.log");
    let server = live_server(&live, port, &sim, &cfg, &log2, &[]);
    let rep = replay(&sim, port, &["--rate", "0"]);
    assert_eq!(rep["clouds"], 24);
    let st = wait_status(&z, 300, &log2, |st| {
        st["live"]["already_mapped"].as_u64() == Some(frames_then)
            && st["live"]["frames_mapped"].as_u64() == Some(24 - frames_then)
    });
    assert_eq!(st["live"]["malformed"], json!({}));
    stop(server, &log2);
    z.close().wait().unwrap();
    // every frame exactly once, numbered without a gap, every observation pointing at one
    let rows = read_query(&live, "MATCH (f:Frame) RETURN f.index AS i ORDER BY i");
    let idx: Vec<u64> = rows
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["i"].as_u64().unwrap())
        .collect();
    assert_eq!(idx, (0..24).collect::<Vec<u64>>());
    // and the map is the one an uninterrupted batch build makes of the same frames
    let batch = dir.path().join("batch.og");
    build_map(&sim, &batch, &["--embedder", "hash"]);
    assert_eq!(
        summary(&batch),
        summary(&live),
        "batch vs killed-and-resumed live"
    );
}

#[test]
fn malformed_samples_are_counted_and_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    json(&og(&["sim", "--out", s(&sim), "--frames", "2", "--json"]));
    let live = dir.path().join("live.og");
    let log = dir.path().join("serve.log");
    let port = free_port();
    let server = live_server(&live, port, &sim, &config(dir.path(), 2.0), &log, &[]);
    let z = client(port);
    use ingest::sources::ros::*;
    let key = |topic: &str, ty: &RosType| og_zenoh::keys::ros_topic(0, topic, ty);
    let cloud = PointCloud2::from_xyzi(Header::default(), &[[1.0, 2.0, 3.0, 0.0]; 4]);
    let good = encode(&cloud).unwrap();
    let mut hostile = vec![
        Vec::new(),
        vec![0, 1, 0],
        good[..good.len() / 2].to_vec(),
        b"\x07\x07\0\0garbage".to_vec(),
    ];
    // a 4 GiB declared width and a field past point_step
    let mut wide = cloud.clone();
    wide.width = u32::MAX;
    hostile.push(encode(&wide).unwrap());
    let mut odd = cloud.clone();
    odd.fields[2].offset = 100;
    hostile.push(encode(&odd).unwrap());
    let pubc = z
        .declare_publisher(key("velodyne_points", &POINT_CLOUD2))
        .wait()
        .unwrap();
    let start = Instant::now();
    while !pubc.matching_status().wait().unwrap().matching() {
        assert!(start.elapsed() < Duration::from_secs(30), "no subscriber");
        std::thread::sleep(Duration::from_millis(20));
    }
    for h in &hostile {
        pubc.put(h.clone()).wait().unwrap();
    }
    // a message of another type on the cloud topic: counted, not decoded
    z.put(
        key("velodyne_points", &STRING),
        encode(&RosString { data: "hi".into() }).unwrap(),
    )
    .wait()
    .unwrap();
    let odom = Odometry {
        pose: PoseWithCovariance {
            pose: Pose {
                orientation: Quaternion {
                    x: f64::NAN,
                    ..Quaternion::default()
                },
                ..Pose::default()
            },
            ..PoseWithCovariance::default()
        },
        ..Odometry::default()
    };
    z.put(key("odom", &ODOMETRY), encode(&odom).unwrap())
        .wait()
        .unwrap();
    z.put(
        key("detections", &STRING),
        encode(&RosString {
            data: "{not json".into(),
        })
        .unwrap(),
    )
    .wait()
    .unwrap();
    let st = wait_status(&z, 60, &log, |st| {
        st["live"]["malformed"]["cloud"] == hostile.len() as u64
            && st["live"]["malformed"]["odometry"] == 1
            && st["live"]["malformed"]["detections"] == 1
            && st["live"]["wrong_type"]["cloud"] == 1
    });
    assert!(
        st["live"]["last_error"]
            .as_str()
            .unwrap()
            .contains("detections"),
        "{st}"
    );
    // nothing reached the store, and the server still answers
    let n = count_instances(&z);
    assert!(n.to_string().contains("\"n\":0"), "{n}");
    // another process cannot open the map the live server writes: the error says where to
    // reach it
    // (the server leaves its note beside the map just after zenoh starts: wait for it)
    let start = Instant::now();
    while !std::fs::exists(dir.path().join("live.og.serving.json")).unwrap() {
        assert!(start.elapsed() < Duration::from_secs(30), "no serving note");
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .args(["info", "--db", s(&live)])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("(mapping live) holds it for writing") && err.contains("http://127.0.0.1:"),
        "{err}"
    );
    z.close().wait().unwrap();
    stop(server, &log);
}

/// The venv's Python when it has PyPI `rosbags` and `eclipse-zenoh` (setup.sh installs them).
fn python_with_ros() -> Option<PathBuf> {
    python_importing("mcp, rosbags, zenoh")
}

/// Messages serialised by PyPI `rosbags` and published by PyPI `eclipse-zenoh` on rmw_zenoh
/// keys are mapped, and the Python session's own query finds the object.
#[test]
fn ros_messages_from_rosbags_over_python_zenoh_are_mapped() {
    let Some(py) = python_with_ros() else {
        eprintln!("skipped: no Python with rosbags and eclipse-zenoh (run scripts/setup.sh)");
        return;
    };
    // the type hashes `replay` publishes with are the ones rosbags computes (REP 2011)
    use ingest::sources::ros::{CAMERA_INFO, ODOMETRY, POINT_CLOUD2, POSE_STAMPED, STRING};
    let types = [POINT_CLOUD2, ODOMETRY, POSE_STAMPED, CAMERA_INFO, STRING];
    let names: Vec<String> = types.iter().map(|t| format!("{:?}", t.name)).collect();
    let out = Command::new(&py)
        .args([
            "-c",
            &format!(
                "from rosbags.typesys import Stores, get_typestore\nts = get_typestore(Stores.ROS2_JAZZY)\nfor t in [{}]: print(ts.hash_rihs01(t))",
                names.join(", ")
            ),
        ])
        .output()
        .unwrap();
    let hashes: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect();
    assert_eq!(
        hashes,
        types.iter().map(|t| t.hash.to_string()).collect::<Vec<_>>()
    );
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("py.toml");
    std::fs::write(
        &cfg,
        "[live]\nidle_finish_secs = 1.0\ncam_from_velo = [0.0, -1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0]\n",
    )
    .unwrap();
    let db = dir.path().join("py.og");
    let log = dir.path().join("serve.log");
    let port = free_port();
    let server = Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .args(["serve", "--db", s(&db), "--bind", "127.0.0.1:0", "--zenoh"])
        .args(["--zenoh-listen", &format!("tcp/127.0.0.1:{port}")])
        .args([
            "--config",
            s(&cfg),
            "--embedder",
            "hash",
            "--map-name",
            "live",
        ])
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/ros_publish.py");
    let mut cmd = Command::new(py);
    cmd.arg(script).arg(format!("tcp/127.0.0.1:{port}"));
    let out = json_of_run(cmd, 180);
    let live = &out["status"]["live"];
    assert_eq!(live["frames_mapped"], 3, "{out}");
    assert_eq!(live["malformed"], json!({}), "{out}");
    assert_eq!(
        live["received"],
        json!({"camera_info": 3, "cloud": 3, "detections": 3, "odometry": 3})
    );
    let best = &out["found"]["results"][0];
    assert_eq!(best["caption"], "a red post box", "{out}");
    // the box is 10 m ahead of the robot: KITTI-style world z forward, y down
    let c = xyz(&best["centroid"]);
    assert!((c[2] - 10.0).abs() < 0.2 && c[0].abs() < 0.2, "{c:?}");
    stop(server, &log);
}

/// `serve --zenoh --no-live` of one region shard, listening on `port`.
fn shard_server(db: &Path, region: &str, port: u16, log: &Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .args(["serve", "--db", s(db), "--bind", "127.0.0.1:0", "--zenoh"])
        .args(["--no-live", "--map-name", "city", "--region", region])
        .args(["--zenoh-listen", &format!("tcp/127.0.0.1:{port}")])
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap()
}

/// `opengraph zenoh-query` over the servers on `ports`: the merged answer.
fn fan_out(ports: &[u16], tool: &str, args: &Json, regions: &str, deadline_secs: &str) -> Json {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_opengraph"));
    cmd.args(["zenoh-query", "--map", "city", tool, &args.to_string()])
        .args(["--deadline-secs", deadline_secs]);
    if !regions.is_empty() {
        cmd.args(["--regions", regions]);
    }
    for p in ports {
        cmd.args(["--zenoh-connect", &format!("tcp/127.0.0.1:{p}")]);
    }
    pretty_json_of_run(cmd)
}

/// Runs `cmd` (2 minutes at most); asserts it succeeded; its whole stdout as JSON.
fn pretty_json_of_run(cmd: Command) -> Json {
    let shown = format!("{cmd:?}");
    let out = output_within(cmd, 120);
    assert!(
        out.status.success(),
        "{shown} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// `opengraph tool` on one store: the tool's answer.
fn tool_on(db: &Path, tool: &str, args: &Json) -> Json {
    json(&og(&["tool", "--db", s(db), tool, &args.to_string()]))
}

/// (id, score) of each result, best first.
fn ranked(answer: &Json, id: &str) -> Vec<(u64, f64)> {
    answer["results"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| (r[id].as_u64().unwrap(), r["score"].as_f64().unwrap()))
        .collect()
}

#[test]
fn three_region_shards_answer_as_the_whole_map_and_a_stopped_one_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    let (_sim, db) = sim_map(
        dir.path(),
        &["--seed", "0", "--frames", "200"],
        &["--embedder", "hash"],
    );
    let out = dir.path().join("shards");
    let split = json(&og(&[
        "shard",
        "--db",
        s(&db),
        "--parts",
        "3",
        "--out",
        s(&out),
        "--json",
    ]));
    let regions = split["regions"].as_array().unwrap();
    assert_eq!(regions.len(), 3, "{split}");
    // every instance of the whole map is in exactly one region, under the same node id
    let ids = |db: &Path| -> Vec<u64> {
        read_query(db, "MATCH (i:Instance) RETURN id(i) AS id ORDER BY id")
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["id"].as_u64().unwrap())
            .collect()
    };
    let whole = ids(&db);
    let mut region_of = std::collections::BTreeMap::new();
    for r in regions {
        let name = r["region"].as_str().unwrap().to_string();
        let own = ids(Path::new(r["db"].as_str().unwrap()));
        assert!(!own.is_empty(), "region {name} holds no instance: {split}");
        for id in own {
            assert!(region_of.insert(id, name.clone()).is_none(), "{id} twice");
        }
    }
    assert_eq!(region_of.keys().copied().collect::<Vec<_>>(), whole);
    // a segment is in one region only
    let segs: u64 = regions
        .iter()
        .map(|r| {
            read_query(
                Path::new(r["db"].as_str().unwrap()),
                "MATCH (s:Segment) RETURN count(*) AS n",
            )[0]["n"]
                .as_u64()
                .unwrap()
        })
        .sum();
    assert_eq!(
        segs,
        read_query(&db, "MATCH (s:Segment) RETURN count(*) AS n")[0]["n"]
            .as_u64()
            .unwrap()
    );

    let ports: Vec<u16> = (0..3).map(|_| free_port()).collect();
    let mut servers: Vec<Option<Child>> = regions
        .iter()
        .zip(&ports)
        .map(|(r, &p)| {
            let name = r["region"].as_str().unwrap();
            Some(shard_server(
                Path::new(r["db"].as_str().unwrap()),
                name,
                p,
                &dir.path().join(format!("{name}.log")),
            ))
        })
        .collect();
    // the whole map as one region of another map name, for the latency against one store
    let whole_port = free_port();
    let whole_log = dir.path().join("whole.log");
    let mut whole_server = Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .args(["serve", "--db", s(&db), "--bind", "127.0.0.1:0", "--zenoh"])
        .args(["--no-live", "--map-name", "whole", "--region", "all"])
        .args(["--zenoh-listen", &format!("tcp/127.0.0.1:{whole_port}")])
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&whole_log).unwrap())
        .spawn()
        .unwrap();
    let z = og_zenoh::SessionOptions::peer(
        &[],
        &ports
            .iter()
            .chain([&whole_port])
            .map(|p| format!("tcp/127.0.0.1:{p}"))
            .collect::<Vec<_>>(),
    )
    .open()
    .unwrap();
    let start = Instant::now();
    for key in [
        "opengraph/city/r1/status",
        "opengraph/city/r2/status",
        "opengraph/city/r3/status",
        "opengraph/whole/all/status",
    ] {
        while !matches!(get(&z, key, None), Some(Ok(_))) {
            assert!(
                start.elapsed() < Duration::from_secs(120),
                "{key} never answered; r1 log:\n{}",
                std::fs::read_to_string(dir.path().join("r1.log")).unwrap_or_default()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    // find: the whole map's answer, by `opengraph tool` on its store, against the fan-out
    let queries = [
        "a bus stop",
        "a bench",
        "a tree",
        "a parked car",
        "a street sign",
        "a trash bin",
        "a bench next to a bus stop",
        "a tree near a street sign",
        "a car parked by the bus stop",
    ];
    let (mut same, mut local_evidence) = (0, 0);
    for q in queries {
        let args = json!({"text": q, "k": 5});
        let one = tool_on(&db, "find_objects", &args);
        let fanned = fan_out(&ports, "find_objects", &args, "r1,r2,r3", "10");
        assert!(fanned["missing"].as_array().unwrap().is_empty(), "{fanned}");
        assert_eq!(fanned["passes"], 2);
        let (a, b) = (ranked(&one, "id"), ranked(&fanned["answer"], "id"));
        for r in fanned["answer"]["results"].as_array().unwrap() {
            assert_eq!(
                r["region"].as_str(),
                region_of
                    .get(&r["id"].as_u64().unwrap())
                    .map(String::as_str)
            );
        }
        // an anchor in another region is not seen: where every result's evidence is in its
        // own region, the answers are the same; elsewhere a region can only score lower
        let local = one["results"].as_array().unwrap().iter().all(|r| {
            let home = &region_of[&r["id"].as_u64().unwrap()];
            r["evidence"].as_array().unwrap().iter().all(|e| {
                region_of
                    .get(&e["anchor_id"].as_u64().unwrap())
                    .is_none_or(|h| h == home)
            })
        });
        let equal = a.len() == b.len()
            && a.iter()
                .zip(&b)
                .all(|(x, y)| x.0 == y.0 && (x.1 - y.1).abs() < 1e-9);
        if local {
            local_evidence += 1;
            assert!(equal, "{q}: one map {a:?}, fanned out {b:?}");
        } else {
            let best_one = a.first().map_or(0.0, |x| x.1);
            assert!(b.iter().all(|y| y.1 <= best_one + 1e-9), "{q}: {a:?} {b:?}");
        }
        same += usize::from(equal);
    }
    eprintln!(
        "find: {same} of {} queries the same over three regions as on the whole map ({local_evidence} with every anchor in its target's region)",
        queries.len()
    );
    assert!(local_evidence >= 6, "the target-only queries at least");

    // locate: three passes; the same where no landmark crosses a region's border
    let args = json!({"text": "I'm at a T-junction with a bus stop and a bench", "k": 3});
    let one = tool_on(&db, "locate", &args);
    let fanned = fan_out(&ports, "locate", &args, "", "10");
    assert_eq!(fanned["passes"], 3, "{fanned}");
    assert_eq!(fanned["regions"], json!(["r1", "r2", "r3"]));
    eprintln!(
        "locate: one map {:?}, fanned out {:?}",
        ranked(&one, "segment"),
        ranked(&fanned["answer"], "segment")
    );
    assert!(!ranked(&fanned["answer"], "segment").is_empty());

    // Cypher: the union of the rows, each with its region
    let cy = fan_out(
        &ports,
        "read_cypher",
        &json!({"query": "MATCH (i:Instance) RETURN count(*) AS n"}),
        "",
        "10",
    );
    let rows = cy["answer"]["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3, "{cy}");
    let total: u64 = rows.iter().map(|r| r["n"].as_u64().unwrap()).sum();
    assert_eq!(total as usize, whole.len());

    // latency: the fan-out over three regions against the whole map as one region
    let args = json!({"text": "a bench next to a bus stop", "k": 5});
    let mut t3 = Vec::new();
    let mut t1 = Vec::new();
    for _ in 0..5 {
        t3.push(
            fan_out(&ports, "find_objects", &args, "r1,r2,r3", "10")["time_ms"]
                .as_f64()
                .unwrap(),
        );
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_opengraph"));
        cmd.args([
            "zenoh-query",
            "--map",
            "whole",
            "find_objects",
            &args.to_string(),
        ])
        .args([
            "--regions",
            "all",
            "--zenoh-connect",
            &format!("tcp/127.0.0.1:{whole_port}"),
        ]);
        t1.push(pretty_json_of_run(cmd)["time_ms"].as_f64().unwrap());
    }
    t3.sort_by(f64::total_cmp);
    t1.sort_by(f64::total_cmp);
    eprintln!(
        "fan-out find latency, median of 5: three regions {:.1} ms, the whole map as one {:.1} ms (ratio {:.2})",
        t3[2],
        t1[2],
        t3[2] / t1[2]
    );

    // a stopped region is reported missing, and the others still answer
    let mut r2 = servers[1].take().unwrap();
    r2.kill().unwrap();
    r2.wait().unwrap();
    let fanned = fan_out(
        &ports,
        "find_objects",
        &json!({"text": "a tree", "k": 5}),
        "r1,r2,r3",
        "2",
    );
    let missing = fanned["missing"].as_array().unwrap();
    assert_eq!(missing.len(), 1, "{fanned}");
    assert_eq!(missing[0]["region"], "r2");
    assert_eq!(fanned["regions"], json!(["r1", "r3"]));
    for r in fanned["answer"]["results"].as_array().unwrap() {
        assert_ne!(r["region"], "r2");
    }
    // only the regions named are asked for
    let one = fan_out(
        &ports,
        "find_objects",
        &json!({"text": "a tree", "k": 5}),
        "r1",
        "2",
    );
    assert_eq!(one["regions"], json!(["r1"]), "{one}");
    assert!(one["missing"].as_array().unwrap().is_empty(), "{one}");
    for r in one["answer"]["results"].as_array().unwrap() {
        assert_eq!(r["region"], "r1");
    }
    // a map no server holds is the caller's mistake
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_opengraph"));
    cmd.args(["zenoh-query", "--map", "nosuchmap", "get_schema", "{}"])
        .args([
            "--deadline-secs",
            "1",
            "--zenoh-connect",
            &format!("tcp/127.0.0.1:{}", ports[0]),
        ]);
    let out = output_within(cmd, 60);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("no region answered"));
    let _ = z.close().wait();
    for mut c in servers.into_iter().flatten() {
        let _ = c.kill();
        let _ = c.wait();
    }
    let _ = whole_server.kill();
    let _ = whole_server.wait();
}

/// The server's HTTP address, from the note it leaves beside the map.
fn http_url(db: &Path) -> String {
    let note = PathBuf::from(format!("{}.serving.json", db.display()));
    let start = Instant::now();
    loop {
        if let Ok(t) = std::fs::read_to_string(&note)
            && let Ok(v) = serde_json::from_str::<Json>(&t)
            && let Some(u) = v["url"].as_str()
        {
            return u.trim_end_matches('/').to_string();
        }
        assert!(start.elapsed() < Duration::from_secs(30), "no serving note");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn map_edits_made_while_mapping_live_stand() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    json(&og(&["sim", "--out", s(&sim), "--frames", "40", "--json"]));
    let live = dir.path().join("live.og");
    let log = dir.path().join("serve.log");
    let (token_file, token) = write_token(dir.path());
    let port = free_port();
    let server = live_server(
        &live,
        port,
        &sim,
        &config(dir.path(), 2.0),
        &log,
        &["--token-file", s(&token_file)],
    );
    let z = client(port);
    wait_status(&z, 60, &log, |_| true);
    let url = http_url(&live);
    let rep = replay(&sim, port, &["--rate", "0", "--frames", "0..1420"]);
    assert_eq!(rep["clouds"], 20, "{rep}");
    // the first part mapped, finished once idle, with its hierarchy
    wait_status(&z, 300, &log, |st| {
        st["live"]["frames_mapped"] == 20 && st["live"]["hierarchy_refreshes"].as_u64() > Some(0)
    });
    // two objects seen in the last frames so far (so the drive goes on seeing them), each
    // with a caption no other object has: one is said to be gone, one repainted
    let (st, rows) = post(
        &format!("{url}/api/cypher"),
        &json!({"query": "MATCH (i:Instance)-[:OBSERVED_IN]->(f:Frame) WHERE f.index >= 15 \
            AND NOT i.semantic_class IN ['road', 'sidewalk', 'parking', 'terrain', 'other-ground', 'building', 'vegetation'] \
            WITH DISTINCT i MATCH (j:Instance) WITH i, sum(CASE WHEN j.caption = i.caption THEN 1 ELSE 0 END) AS same \
            WHERE same = 1 RETURN id(i) AS id, i.caption AS caption ORDER BY id LIMIT 2"}),
        None,
    );
    assert_eq!(st, 200, "{rows}");
    let rows = rows["rows"].as_array().cloned().unwrap_or_default();
    assert_eq!(rows.len(), 2, "two objects to edit: {rows:?}");
    let (gone, gone_caption) = (
        rows[0]["id"].as_u64().unwrap(),
        rows[0]["caption"].as_str().unwrap().to_string(),
    );
    let (painted, painted_caption) = (
        rows[1]["id"].as_u64().unwrap(),
        rows[1]["caption"].as_str().unwrap().to_string(),
    );
    for text in [
        format!("{gone_caption} is gone"),
        format!("{painted_caption} is now purple"),
    ] {
        let (st, v) = post(
            &format!("{url}/api/update"),
            &json!({"text": text, "apply": true}),
            Some(&token),
        );
        assert_eq!(st, 200, "{text}: {v}");
        assert!(v["applied"]["edit_id"].as_u64().is_some(), "{text}: {v}");
    }
    let caption_now = |id: u64| {
        let (st, v) = common::get(&format!("{url}/api/instances/{id}"));
        (st, v["properties"]["caption"].as_str().map(str::to_string))
    };
    let edited = caption_now(painted).1.unwrap();
    assert!(edited.contains("purple"), "{edited}");
    // the rest of the drive: mapped and finished again, with no write refused
    let rep = replay(&sim, port, &["--rate", "0", "--frames", "1420..2853"]);
    assert_eq!(rep["clouds"], 20, "{rep}");
    let st = wait_status(&z, 300, &log, |st| {
        st["live"]["frames_mapped"] == 40 && st["live"]["hierarchy_refreshes"].as_u64() > Some(1)
    });
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(
        !text.contains("live mapping:"),
        "a live write failed:\n{text}"
    );
    assert!(st["live"]["last_error"].is_null(), "{st}");
    // the edits stand
    assert_eq!(caption_now(gone).0, 404, "the removed instance is back");
    assert_eq!(
        caption_now(painted).1.as_deref(),
        Some(edited.as_str()),
        "the new caption was overwritten"
    );
    assert!(text.contains("was changed by another writer"), "{text}");
    z.close().wait().unwrap();
    stop(server, &log);
}
