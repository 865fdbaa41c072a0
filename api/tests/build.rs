//! `opengraph build`, `oracle` and `eval semseg` on the real KITTI sequence-00 scans in
//! `../shared/data` (skipped with a message when it is absent): the oracle map, the same map
//! through detections files, resume after SIGKILL, and clear errors for bad input.

use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

mod common;
use common::{export, json, og, ok, point_clouds, s};

fn seq00() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/kitti/sequences/00");
    if p.join("labels/000000.label").exists() {
        Some(p)
    } else {
        eprintln!("skipping: {} not found", p.display());
        None
    }
}

/// The embedder the tests use: MiniLM when installed, else the hash embedder.
fn embedder() -> &'static str {
    let dir = std::env::var("OPENGRAPH_MODELS")
        .map(PathBuf::from)
        .unwrap_or_else(|_| {
            PathBuf::from(std::env::var("HOME").unwrap()).join(".cache/opengraph/models")
        });
    if dir.join("all-MiniLM-L6-v2.int8.onnx").exists() {
        "minilm"
    } else {
        eprintln!("MiniLM not installed: using the hash embedder");
        "hash"
    }
}

/// A copy of frames 0..3 of sequence 00 (scans, labels, calib, poses, times) to damage.
fn copy_seq(src: &Path, dst: &Path) {
    for d in ["velodyne", "labels"] {
        std::fs::create_dir_all(dst.join(d)).unwrap();
    }
    for i in 0..3 {
        for (d, ext) in [("velodyne", "bin"), ("labels", "label")] {
            let name = format!("{d}/{i:06}.{ext}");
            std::fs::copy(src.join(&name), dst.join(&name)).unwrap();
        }
    }
    for f in ["calib.txt", "poses.txt", "times.txt"] {
        std::fs::copy(src.join(f), dst.join(f)).unwrap();
    }
}

#[test]
fn oracle_build_on_real_scans_then_eval() {
    let Some(seq) = seq00() else { return };
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("map.og");
    let r = json(&og(&[
        "build",
        "--kitti",
        s(&seq),
        "--oracle-labels",
        "--db",
        s(&db),
        "--embedder",
        embedder(),
        "--json",
    ]));
    assert_eq!(r["frames_total"], 3);
    assert_eq!(r["source"], "oracle");
    let classes = r["instances_per_class"].as_object().unwrap();
    for c in ["car", "road", "building", "vegetation", "sidewalk"] {
        assert!(
            classes.get(c).is_some_and(|n| n.as_u64() > Some(0)),
            "{c}: {r}"
        );
    }
    assert!(r["hierarchy"]["lane_edges"].as_u64() > Some(10), "{r}");
    for stage in ["project", "denoise", "associate", "fuse", "embed"] {
        assert!(r["ms_per_frame"][stage].as_f64().is_some(), "{stage}");
    }
    let info = json(&og(&["info", "--db", s(&db), "--json"]));
    assert_eq!(info["nodes"]["Frame"], 3);
    assert_eq!(info["nodes"]["Build"], 1);
    assert!(
        info["relationships"]["OBSERVED_IN"].as_u64() > Some(20),
        "{info}"
    );
    assert!(
        info["relationships"]["IN_SEGMENT"].as_u64() > Some(20),
        "{info}"
    );
    let e = json(&og(&[
        "eval",
        "semseg",
        "--db",
        s(&db),
        "--kitti",
        s(&seq),
        "--json",
    ]));
    assert_eq!(e["source"], "oracle");
    assert_eq!(e["scans"], 3);
    let miou = e["miou"].as_f64().unwrap();
    let in_view = e["in_view"]["miou"].as_f64().unwrap();
    eprintln!("oracle map: mIoU {miou:.3} (all points), {in_view:.3} in camera view");
    // the camera sees about a quarter of each 360° scan
    assert!(miou > 0.1 && miou < in_view, "{e}");
    if embedder() == "minilm" {
        assert!(in_view > 0.5, "{e}");
    }
    assert!(e["per_class"]["car"]["iou"].as_f64() > Some(0.2), "{e}");
    // a second build into the same store is refused without --resume
    let out = og(&[
        "build",
        "--kitti",
        s(&seq),
        "--oracle-labels",
        "--db",
        s(&db),
        "--embedder",
        embedder(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--resume"));
}

#[test]
fn detections_files_give_the_same_map_as_the_oracle() {
    let Some(seq) = seq00() else { return };
    let dir = tempfile::tempdir().unwrap();
    let dets = dir.path().join("dets");
    ok(&og(&["oracle", "--kitti", s(&seq), "--out", s(&dets)]));
    assert!(dets.join("000002.json").exists());
    let (a, b) = (dir.path().join("a.og"), dir.path().join("b.og"));
    let ra = json(&og(&[
        "build",
        "--kitti",
        s(&seq),
        "--oracle-labels",
        "--db",
        s(&a),
        "--embedder",
        "hash",
        "--json",
    ]));
    let rb = json(&og(&[
        "build",
        "--kitti",
        s(&seq),
        "--detections",
        s(&dets),
        "--db",
        s(&b),
        "--embedder",
        "hash",
        "--json",
    ]));
    assert_eq!(rb["source"], "detections");
    assert_eq!(ra["instances_per_class"], rb["instances_per_class"]);
    assert_eq!(ra["detections"], rb["detections"]);
}

/// Builds with a commit after every key frame, SIGKILLs the process right after the commit
/// of `kill_after`, resumes, and checks the result equals an uninterrupted build.
fn kill_and_resume(seq: &Path, kill_after: u32) {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("cfg.toml");
    std::fs::write(&cfg, "[mapping]\ncommit_every = 1\naccumulate = 2\n").unwrap();
    let (whole, killed) = (dir.path().join("whole.og"), dir.path().join("killed.og"));
    let base = |db: &Path| -> Vec<String> {
        [
            "build",
            "--kitti",
            s(seq),
            "--oracle-labels",
            "--frames",
            "0..3",
            "--config",
            s(&cfg),
            "--embedder",
            "hash",
            "--db",
            s(db),
        ]
        .iter()
        .map(|x| x.to_string())
        .collect()
    };
    ok(&og(&base(&whole)
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>()));

    let mut child = Command::new(env!("CARGO_BIN_EXE_opengraph"))
        .args(base(&killed))
        .env("OPENGRAPH_BUILD_PAUSE_AFTER_COMMIT_MS", "30000")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stderr)
            .lines()
            .map_while(Result::ok)
        {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let want = format!("committed through frame {kill_after}");
    loop {
        let line = rx
            .recv_timeout(Duration::from_secs(120))
            .expect("build reports its commits");
        if line.contains(&want) {
            break;
        }
    }
    child.kill().unwrap(); // SIGKILL
    let status = child.wait().unwrap();
    assert!(!status.success());

    let mut resume = base(&killed);
    resume.push("--resume".into());
    resume.push("--json".into());
    let r = json(&og(&resume.iter().map(String::as_str).collect::<Vec<_>>()));
    assert_eq!(r["resumed_at"], kill_after + 1, "{r}");
    assert_eq!(r["frames_run"], 2 - kill_after, "{r}");

    let ga = export(&whole, &dir.path().join("a.json"));
    let gb = export(&killed, &dir.path().join("b.json"));
    assert_eq!(ga, gb, "resumed graph differs from the uninterrupted one");
    assert_eq!(point_clouds(&whole), point_clouds(&killed));
    let store = graphstore::Store::open(&killed).unwrap();
    assert_eq!(store.check_consistency().unwrap(), Vec::<String>::new());
}

#[test]
fn a_killed_build_resumes_to_the_same_graph() {
    let Some(seq) = seq00() else { return };
    kill_and_resume(&seq, 0);
    kill_and_resume(&seq, 1);
}

/// Cuts the last `n` bytes off a file.
fn chop(path: &Path, n: usize) {
    let bytes = std::fs::read(path).unwrap();
    std::fs::write(path, &bytes[..bytes.len() - n]).unwrap();
}

/// Rewrites a JSON file through `f`.
fn edit_json(path: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(path, serde_json::to_vec(&v).unwrap()).unwrap();
}

fn expect_input_error(args: &[&str], needles: &[&str]) {
    let out = og(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: missing {n:?} in {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_input_is_a_clear_error_naming_the_file() {
    let Some(seq) = seq00() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mk = |name: &str| {
        let d = dir.path().join(name);
        copy_seq(&seq, &d);
        d
    };
    let build = |d: &Path, db: &str, extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = [
            "build",
            "--kitti",
            s(d),
            "--embedder",
            "hash",
            "--db",
            s(&dir.path().join(db)),
        ]
        .iter()
        .map(|x| x.to_string())
        .collect();
        v.extend(extra.iter().map(|x| x.to_string()));
        v
    };
    let run = |v: Vec<String>, needles: &[&str]| {
        expect_input_error(&v.iter().map(String::as_str).collect::<Vec<_>>(), needles)
    };
    // a scan whose size is not a multiple of 16 bytes
    let d = mk("truncated");
    chop(&d.join("velodyne/000001.bin"), 7);
    run(
        build(&d, "t.og", &["--oracle-labels"]),
        &["000001.bin", "not a multiple of 16"],
    );
    // a label count that does not match the scan
    let d = mk("labels");
    chop(&d.join("labels/000002.label"), 8);
    run(
        build(&d, "l.og", &["--oracle-labels"]),
        &["000002.label", "labels for a scan"],
    );
    // a calib without Tr
    let d = mk("calib");
    let text = std::fs::read_to_string(d.join("calib.txt")).unwrap();
    let no_tr: String = text
        .lines()
        .filter(|l| !l.starts_with("Tr"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(d.join("calib.txt"), no_tr).unwrap();
    run(
        build(&d, "c.og", &["--oracle-labels"]),
        &["calib.txt", "no Tr"],
    );
    // fewer poses than scans
    let d = mk("poses");
    let text = std::fs::read_to_string(d.join("poses.txt")).unwrap();
    let two: String = text.lines().take(2).map(|l| format!("{l}\n")).collect();
    std::fs::write(d.join("poses.txt"), two).unwrap();
    run(
        build(&d, "p.og", &["--oracle-labels"]),
        &["poses.txt", "fewer poses than scans"],
    );
    // a --frames range with none of the scans (a range beyond the last scan takes the ones
    // it holds), and a config with an unknown key
    let d = mk("ok");
    run(
        build(&d, "f.og", &["--oracle-labels", "--frames", "5..9"]),
        &["--frames 5..9", "holds none"],
    );
    let cfg = dir.path().join("bad.toml");
    std::fs::write(&cfg, "[mapping]\nvoxel_m = 0.1\nsim_treshold = 0.5\n").unwrap();
    run(
        build(&d, "g.og", &["--oracle-labels", "--config", s(&cfg)]),
        &["bad.toml:3", "sim_treshold"],
    );
    // detections: an invalid RLE, and masks whose size differs from the image
    let dets = dir.path().join("dets");
    ok(&og(&["oracle", "--kitti", s(&d), "--out", s(&dets)]));
    edit_json(&dets.join("000001.json"), |v| {
        v["detections"][0]["mask"]["counts"] = serde_json::json!([5, 3]);
    });
    run(
        build(&d, "r.og", &["--detections", s(&dets)]),
        &["000001.json", "invalid RLE"],
    );
    edit_json(&dets.join("000000.json"), |v| {
        v["image"]["width"] = serde_json::json!(1241);
        for det in v["detections"].as_array_mut().unwrap() {
            det["mask"] = serde_json::json!({"size": [375, 1241], "counts": [375 * 1241]});
        }
    });
    run(
        build(&d, "m.og", &["--detections", s(&dets), "--frames", "0..1"]),
        &["000000.json", "1241x375", "1242x375"],
    );
    // NaN points are dropped and counted
    let d = mk("nan");
    let scan = d.join("velodyne/000000.bin");
    let mut bytes = std::fs::read(&scan).unwrap();
    for k in 0..10 {
        bytes[k * 16..k * 16 + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    }
    bytes[160..164].copy_from_slice(&f32::INFINITY.to_le_bytes());
    std::fs::write(&scan, bytes).unwrap();
    let db = dir.path().join("n.og");
    let r = json(&og(&[
        "build",
        "--kitti",
        s(&d),
        "--oracle-labels",
        "--embedder",
        "hash",
        "--db",
        s(&db),
        "--json",
    ]));
    assert_eq!(r["nonfinite_points"], 11);
}
