//! The Python package for real: builds the wheel with maturin, installs it into the
//! project's virtual environment ($OPENGRAPH_VENV, made by scripts/setup.sh), and runs its
//! pytest suite (`api/python/tests`) on a simulated city's map and, where `../shared/data` is
//! there, the KITTI sample's oracle map. Skips with a message when the environment lacks
//! maturin or pytest.

mod common;
use common::{og, ok, s, sim_map};

#[test]
fn the_python_package_passes_its_pytest_suite() {
    let Some(py) = common::python_with_mcp() else {
        eprintln!("skipping: no project Python environment (run scripts/setup.sh)");
        return;
    };
    let has = |m: &str| {
        std::process::Command::new(&py)
            .args(["-c", &format!("import {m}")])
            .status()
            .is_ok_and(|s| s.success())
    };
    if !has("maturin") || !has("pytest") {
        eprintln!("skipping: no maturin or pytest in the project's Python (run scripts/setup.sh)");
        return;
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = tempfile::tempdir().unwrap();
    // the wheel, built into the shared target folder (so it reuses the workspace's build)
    let wheels = dir.path().join("wheels");
    let t0 = std::time::Instant::now();
    let mut maturin = std::process::Command::new(&py);
    // the variables `cargo test` sets for this test (CARGO_MANIFEST_DIR, CARGO_PKG_*, ...) would
    // reach the nested cargo, which counts them as changes for build scripts that read them
    // (ring's reads CARGO_MANIFEST_DIR) and rebuilds half the workspace over the test build's
    // artifacts
    for (k, _) in std::env::vars_os() {
        let k = k.to_string_lossy();
        if [
            "CARGO_PKG_",
            "CARGO_MANIFEST_",
            "CARGO_CRATE_",
            "CARGO_BIN_",
        ]
        .iter()
        .any(|p| k.starts_with(p))
            || ["CARGO_PRIMARY_PACKAGE", "CARGO_TARGET_TMPDIR", "OUT_DIR"].contains(&k.as_ref())
        {
            maturin.env_remove(k.as_ref());
        }
    }
    let built = maturin
        // the native `linux` tag: the wheel links this machine's OMPL (scripts/setup.sh)
        .args([
            "-m",
            "maturin",
            "build",
            "--quiet",
            "--strip",
            "--compatibility",
            "linux",
            "--auditwheel",
            "skip",
            "-m",
        ])
        .arg(root.join("api/python/Cargo.toml"))
        .arg("-o")
        .arg(&wheels)
        .output()
        .unwrap();
    assert!(
        built.status.success(),
        "maturin build failed:\n{}",
        String::from_utf8_lossy(&built.stderr)
    );
    let wheel = std::fs::read_dir(&wheels)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "whl"))
        .expect("a wheel");
    eprintln!(
        "wheel {} ({} KiB) built in {:.1} s",
        wheel.display(),
        std::fs::metadata(&wheel).unwrap().len() / 1024,
        t0.elapsed().as_secs_f64()
    );
    let installed = std::process::Command::new(&py)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "--force-reinstall",
            "--no-deps",
        ])
        .arg(&wheel)
        .output()
        .unwrap();
    assert!(
        installed.status.success(),
        "pip install failed:\n{}",
        String::from_utf8_lossy(&installed.stderr)
    );
    let (sim, db) = sim_map(
        dir.path(),
        &["--seed", "3", "--frames", "24"],
        &["--embedder", "hash"],
    );
    let mut pytest = std::process::Command::new(&py);
    pytest
        .args(["-m", "pytest", "-q", "-s", "-p", "no:cacheprovider"])
        .arg(root.join("api/python/tests"))
        .env("OPENGRAPH_TEST_MAP", &db)
        .env("OPENGRAPH_TEST_SIM", &sim)
        .env("OPENGRAPH_TEST_DIR", dir.path())
        .env("OPENGRAPH_BIN", env!("CARGO_BIN_EXE_opengraph"));
    let kitti = root.join("../shared/data/kitti/sequences/00");
    if kitti.join("labels").is_dir() {
        let k = dir.path().join("kitti00.og");
        ok(&og(&[
            "build",
            "--kitti",
            s(&kitti),
            "--oracle-labels",
            "--embedder",
            "hash",
            "--db",
            s(&k),
        ]));
        pytest.env("OPENGRAPH_TEST_KITTI_MAP", &k);
    } else {
        eprintln!("note: ../shared/data absent; the KITTI sample map's test is skipped");
    }
    let out = common::output_within(pytest, 900);
    let text = String::from_utf8_lossy(&out.stdout);
    eprintln!("{text}");
    assert!(
        out.status.success(),
        "pytest failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains(" passed"), "{text}");
}
