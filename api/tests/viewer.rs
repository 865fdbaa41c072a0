//! The web viewer in a real browser: headless Chromium (Debian `chromium`, installed by
//! scripts/setup.sh) loads the page from `opengraph serve`, runs a search for each mode (find,
//! locate, route) through the page's own search box, and the test checks that the results are
//! listed and highlighted, that the page logged no errors, and takes a screenshot. Skips with a
//! message when Chromium is not installed.

mod common;
use common::{serve, sim_map};

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

fn chromium() -> Option<&'static str> {
    ["chromium", "chromium-browser"].into_iter().find(|c| {
        Command::new(c)
            .arg("--version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    })
}

/// Runs headless Chromium with `args` and the URL; (stdout, stderr), killed after 120 s.
fn browse(bin: &str, args: &[&str], url: &str, profile: &Path) -> (String, String) {
    let child = Command::new(bin)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--no-first-run",
            "--window-size=1280,800",
            "--virtual-time-budget=30000",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .arg(url)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    let out = match rx.recv_timeout(Duration::from_secs(120)) {
        Ok(o) => o.unwrap(),
        Err(_) => {
            let _ = Command::new("kill").arg(pid.to_string()).status();
            panic!("chromium did not finish within 120 s");
        }
    };
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn attr(dom: &str, name: &str) -> Option<String> {
    let body = &dom[dom.find("<body")?..];
    let tag = &body[..body.find('>')?];
    let key = format!("{name}=\"");
    let start = tag.find(&key)? + key.len();
    Some(tag[start..start + tag[start..].find('"')?].to_string())
}

#[test]
fn the_viewer_searches_and_highlights_in_headless_chromium() {
    let Some(bin) = chromium() else {
        eprintln!("skipping: no chromium (run scripts/setup.sh, which installs Debian's chromium)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (_, db) = sim_map(
        dir.path(),
        &["--seed", "3", "--frames", "24"],
        &["--embedder", "hash"],
    );
    let srv = serve(&db, &[]);
    let profile = dir.path().join("chromium-profile");
    for (mode, q) in [
        ("find", "the bench near the bus stop"),
        ("locate", "I'm at a T-junction next to a bus stop"),
        ("route", "from the T-junction to a bus stop"),
    ] {
        let url = format!(
            "{}/?mode={mode}&q={}",
            srv.url,
            q.replace(' ', "%20").replace('\'', "%27")
        );
        let (dom, log) = browse(bin, &["--dump-dom"], &url, &profile);
        assert_eq!(
            attr(&dom, "data-state").as_deref(),
            Some("done"),
            "{mode}: the search did not finish\n{log}"
        );
        let n: usize = attr(&dom, "data-highlighted").unwrap().parse().unwrap();
        assert!(n >= 1, "{mode}: nothing highlighted");
        if mode == "find" {
            // one highlighted ring per listed result
            assert_eq!(
                dom.matches("class=\"result\" data-id=").count(),
                n,
                "{mode}"
            );
        }
        assert!(
            attr(&dom, "data-errors").is_none(),
            "{mode}: the page logged errors:\n{dom}"
        );
        let errors = dom
            .split("<div id=\"errors\"")
            .nth(1)
            .and_then(|t| t.split("</div>").next())
            .unwrap_or_default();
        assert!(!errors.contains("<div>"), "{mode}: {errors}");
        assert!(!log.contains("Uncaught"), "{mode}: {log}");
    }
    // a screenshot of a search, for people (and a check that the page renders)
    let shot = dir.path().join("find.png");
    let url = format!(
        "{}/?mode=find&q=the%20bench%20near%20the%20bus%20stop",
        srv.url
    );
    browse(
        bin,
        &[&format!("--screenshot={}", shot.display())],
        &url,
        &profile,
    );
    let png = std::fs::read(&shot).expect("a screenshot");
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 20_000,
        "{} bytes",
        png.len()
    );
    if let Some(keep) = std::env::var_os("OPENGRAPH_KEEP_SCREENSHOT") {
        std::fs::copy(&shot, keep).unwrap();
    }
}
