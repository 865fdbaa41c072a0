//! A seeded, time-boxed mutation fuzzer for stable Rust (the fuzz targets are ordinary
//! tests; no nightly toolchain or libFuzzer exists here).
//!
//! [`fuzz`] first replays every committed regression input of the target
//! (`REGRESSIONS/NAME/*`), then mutates the seeds (bit flips, interesting bytes, deletions,
//! duplications, insertions, splices, truncations and dictionary tokens; one to four per
//! case) with a ChaCha8 RNG seeded from `OG_FUZZ_SEED` (default 0), calling the target on
//! each, until `OG_FUZZ_SECS` seconds (default 1) have passed. A panicking input is written to
//! `REGRESSIONS/NAME/crash-HASH` (commit it: it then runs on every test run) and the run
//! fails naming it.

#![doc = include_str!("../README.md")]

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// What one target run did.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The target's name.
    pub name: String,
    /// Inputs tried (regressions included).
    pub cases: u64,
    /// Committed regression inputs replayed first.
    pub regressions: usize,
    /// Seconds spent.
    pub secs: f64,
}

/// The time budget per target: `OG_FUZZ_SECS` seconds (default 1, at most a day).
pub fn budget() -> Duration {
    let secs = std::env::var("OG_FUZZ_SECS")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .unwrap_or(1.0)
        .min(86_400.0);
    Duration::from_secs_f64(secs)
}

/// Tokens worth inserting into text inputs.
const DICTIONARY: &[&[u8]] = &[
    b"-",
    b"0",
    b"-1",
    b"1e308",
    b"nan",
    b"NaN",
    b"inf",
    b"-inf",
    b"18446744073709551616",
    b"9223372036854775808",
    b"\"",
    b"'",
    b"\\",
    b"{",
    b"}",
    b"[",
    b"]",
    b"(",
    b")",
    b":",
    b",",
    b"\n",
    b"\r\n",
    b"\t",
    b" ",
    b"\0",
    b"\xff",
    b"\xc3\x28",
    b"null",
    b"true",
    b"1.5",
    b"0.0/0.0",
    b"MATCH",
    b"RETURN",
    b"WITH",
    b"UNWIND",
    b"CREATE",
    b"DELETE",
    b"SET",
    b"$p",
    b"*",
    b"..",
    b"=~",
    b"count(*)",
    b"[]",
    b"{}",
    b"\xe2\x80\xa8",
];

fn mutate(rng: &mut ChaCha8Rng, input: &mut Vec<u8>, seeds: &[Vec<u8>]) {
    let n = rng.random_range(1..=4);
    for _ in 0..n {
        let len = input.len();
        match rng.random_range(0..9) {
            0 if len > 0 => {
                let i = rng.random_range(0..len);
                input[i] ^= 1 << rng.random_range(0..8);
            }
            1 if len > 0 => {
                let i = rng.random_range(0..len);
                input[i] = [0u8, 0x7f, 0x80, 0xff, b'9', b'.', b'-'][rng.random_range(0..7)];
            }
            2 if len > 0 => {
                let a = rng.random_range(0..len);
                let b = (a + rng.random_range(1..=16)).min(len);
                input.drain(a..b);
            }
            3 if len > 0 && len < 1 << 20 => {
                let a = rng.random_range(0..len);
                let b = (a + rng.random_range(1..=64)).min(len);
                let piece = input[a..b].to_vec();
                let at = rng.random_range(0..=input.len());
                input.splice(at..at, piece);
            }
            4 => {
                let at = rng.random_range(0..=len);
                let k = rng.random_range(1..=8);
                let bytes: Vec<u8> = (0..k).map(|_| rng.random()).collect();
                input.splice(at..at, bytes);
            }
            5 if !seeds.is_empty() => {
                let other = &seeds[rng.random_range(0..seeds.len())];
                if !other.is_empty() {
                    let a = rng.random_range(0..other.len());
                    let b = (a + rng.random_range(1..=64)).min(other.len());
                    let at = rng.random_range(0..=len);
                    input.splice(at..at, other[a..b].iter().copied());
                }
            }
            6 if len > 0 => {
                input.truncate(rng.random_range(0..len));
            }
            _ => {
                let tok = DICTIONARY[rng.random_range(0..DICTIONARY.len())];
                let at = rng.random_range(0..=len);
                input.splice(at..at, tok.iter().copied());
            }
        }
    }
}

fn fnv(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Runs target `name` over its regressions in `regressions/name/`, then mutated `seeds`,
/// for [`budget`]. `target` must not panic on any input: a panic is saved as a regression
/// and fails the run after the budget.
///
/// # Panics
/// When an input made the target panic (naming the saved file), or the seeds are empty.
pub fn fuzz(
    name: &str,
    seeds: &[Vec<u8>],
    regressions: &Path,
    mut target: impl FnMut(&[u8]),
) -> Report {
    assert!(!seeds.is_empty(), "fuzz target {name} has no seeds");
    let dir = regressions.join(name);
    let t0 = Instant::now();
    let mut cases = 0u64;
    let mut crashes: Vec<PathBuf> = Vec::new();
    let mut run = |input: &[u8], save: bool, crashes: &mut Vec<PathBuf>| {
        if catch_unwind(AssertUnwindSafe(|| target(input))).is_err() {
            let path = dir.join(format!("crash-{:016x}", fnv(input)));
            if save {
                let _ = std::fs::create_dir_all(&dir);
                let _ = std::fs::write(&path, input);
            }
            crashes.push(path);
        }
    };
    // committed regressions first
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|rd| rd.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    files.sort();
    for f in &files {
        if let Ok(bytes) = std::fs::read(f) {
            run(&bytes, false, &mut crashes);
            cases += 1;
        }
    }
    for s in seeds {
        run(s, true, &mut crashes);
        cases += 1;
    }
    let seed = std::env::var("OG_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0u64);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ fnv(name.as_bytes()));
    let budget = budget();
    let mut input = Vec::new();
    while t0.elapsed() < budget && crashes.len() < 10 {
        // start again from a seed now and then, so mutations do not drift too far
        if cases.is_multiple_of(2) || input.len() > 1 << 20 {
            input = seeds[rng.random_range(0..seeds.len())].clone();
        }
        mutate(&mut rng, &mut input, seeds);
        run(&input, true, &mut crashes);
        cases += 1;
    }
    let report = Report {
        name: name.to_string(),
        cases,
        regressions: files.len(),
        secs: t0.elapsed().as_secs_f64(),
    };
    eprintln!(
        "fuzz {name}: {} cases in {:.1} s ({} regressions replayed), seed {seed}",
        report.cases, report.secs, report.regressions
    );
    assert!(
        crashes.is_empty(),
        "fuzz {name}: {} input(s) made the target panic; saved as {:?} (commit them as regressions)",
        crashes.len(),
        crashes
    );
    report
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panicking_target_is_caught_and_saved() {
        let dir = std::env::temp_dir().join(format!("og-fuzz-test-{}", std::process::id()));
        // panics on anything but its seed: the first mutation does it
        let r = catch_unwind(AssertUnwindSafe(|| {
            fuzz("panics", &[b"abc".to_vec()], &dir, |b| {
                assert_eq!(b, b"abc");
            })
        }));
        let msg = r
            .err()
            .and_then(|e| e.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        assert!(msg.contains("crash-"), "{msg}");
        let saved: Vec<_> = std::fs::read_dir(dir.join("panics"))
            .unwrap()
            .flatten()
            .collect();
        assert!(!saved.is_empty() && saved.len() <= 10);
        // a saved crash is replayed first on the next run
        let r = catch_unwind(AssertUnwindSafe(|| {
            fuzz("panics", &[b"abc".to_vec()], &dir, |b| {
                assert_eq!(b, b"abc");
            })
        }));
        assert!(r.is_err());
        let _ = std::fs::remove_dir_all(&dir);
        // a target that never panics reports its cases
        let r = fuzz("never", &[b"x".to_vec()], &dir, |_| {});
        assert!(r.cases >= 1);
        assert_eq!(r.regressions, 0);
    }

    #[test]
    fn mutations_are_deterministic_for_a_seed() {
        let seeds = vec![b"MATCH (n) RETURN n".to_vec()];
        let run = || {
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            let mut v = seeds[0].clone();
            for _ in 0..50 {
                mutate(&mut rng, &mut v, &seeds);
            }
            v
        };
        assert_eq!(run(), run());
    }
}
