//! Graph-aware retrieval on the default small simulated city with MiniLM: requests that name
//! an anchor or a function find what plain cosine ranking misses, each answer carries its
//! evidence, surfaces are answers only when asked for, and `eval retrieval` scores both
//! rankings on the repository's query set. Skips when the MiniLM files are absent.

mod common;
use common::{json, og, read_query, s, sim_map};

fn minilm_present() -> bool {
    let d = llm_tools::embed::default_models_dir();
    d.join("all-MiniLM-L6-v2.int8.onnx").exists()
        && d.join("all-MiniLM-L6-v2.tokenizer.json").exists()
}

fn r_at_1(report: &serde_json::Value, kind: &str) -> f64 {
    report["per_type"][kind]["r_at_1"].as_f64().unwrap()
}

#[test]
fn graph_aware_find_beats_plain_ranking_on_the_small_city() {
    if !minilm_present() {
        eprintln!("skipping: the MiniLM files are not there (run scripts/setup.sh)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (sim, db) = sim_map(dir.path(), &["--size", "small", "--seed", "0"], &[]);
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../ingest/eval/data");
    let eval_on = |file: &str, extra: &[&str]| {
        let queries = data.join(file);
        let mut args = vec![
            "eval",
            "retrieval",
            "--db",
            s(&db),
            "--sim",
            s(&sim),
            "--queries",
            s(&queries),
            "--json",
        ];
        args.extend_from_slice(extra);
        json(&og(&args))
    };
    let eval = |extra: &[&str]| eval_on("retrieval_small_city.jsonl", extra);
    let plain = eval(&["--plain"]);
    let graph = eval(&[]);
    // the held-out half of the set generated from the simulator's truth (never tuned on):
    // measured 1.000 / 0.889 / 0.818; the goal of 0.85 functional is not met yet,
    // so this guards what there is
    let held_out = eval_on("retrieval_generated_heldout.jsonl", &[]);
    assert!(r_at_1(&held_out, "named") >= 0.9, "{held_out}");
    assert!(r_at_1(&held_out, "relational") >= 0.8, "{held_out}");
    assert!(r_at_1(&held_out, "functional") >= 0.75, "{held_out}");
    assert!(
        graph["unanswerable"].as_array().unwrap().is_empty(),
        "{graph}"
    );
    // the anchors and the functions are what the graph-aware ranking adds
    assert!(
        r_at_1(&graph, "relational") >= r_at_1(&plain, "relational") + 0.3,
        "plain {plain} graph {graph}"
    );
    // the goals: R@1 >= 0.9 named, >= 0.8 relational and functional (measured 0.962,
    // 0.885 and 0.955 on this city)
    assert!(r_at_1(&graph, "relational") >= 0.8, "{graph}");
    assert!(
        r_at_1(&graph, "functional") >= r_at_1(&plain, "functional"),
        "plain {plain} graph {graph}"
    );
    assert!(r_at_1(&graph, "functional") >= 0.8, "{graph}");
    assert!(r_at_1(&graph, "named") >= 0.9, "{graph}");
    // road areas measured from the map fit the simulator's roads far better than the
    // trajectory's discs and corridors
    let roads = json(&og(&[
        "eval",
        "roads",
        "--db",
        s(&db),
        "--sim",
        s(&sim),
        "--json",
    ]));
    let (before, after) = (
        roads["mean_iou_before"].as_f64().unwrap(),
        roads["mean_iou_after"].as_f64().unwrap(),
    );
    assert!(after >= 0.85 && after >= before + 0.2, "{roads}");

    let find = |text: &str| -> Vec<serde_json::Value> {
        json(&og(&["find", "--db", s(&db), text, "-k", "5", "--json"]))
            .as_array()
            .unwrap()
            .clone()
    };
    // evidence: the anchor that supports the answer, with its distance
    let hits = find("the bench near the bus stop");
    let e = &hits[0]["evidence"][0];
    assert_eq!(e["anchor"], "the bus stop", "{e}");
    assert_eq!(e["relation"], "near");
    assert!(e["distance_m"].as_f64().unwrap() < 8.0, "{e}");
    assert!(
        e["anchor_caption"]
            .as_str()
            .unwrap()
            .to_lowercase()
            .contains("bus"),
        "{e}"
    );
    // surfaces only when asked for
    let surfaces = ["road", "sidewalk", "parking", "terrain", "other-ground"];
    for h in find("who could I ask for directions") {
        assert!(
            !surfaces.contains(&h["semantic_class"].as_str().unwrap()),
            "{h}"
        );
    }
    assert!(
        find("the asphalt road")
            .iter()
            .all(|h| surfaces.contains(&h["semantic_class"].as_str().unwrap())),
    );
    // a segment constraint is reported on each result, and the best answer stands at (or
    // within 10 m of) a T-junction's 12 m disc
    let hits = find("a car at the T-junction");
    assert!(hits.iter().all(|h| !h["segment_match"].is_null()));
    let t_junctions = read_query(
        &db,
        "MATCH (s:Segment {kind: 't_intersection'}) RETURN s.centroid AS c",
    );
    let c = &hits[0]["centroid"];
    let (x, z) = (c[0].as_f64().unwrap(), c[2].as_f64().unwrap());
    let nearest = t_junctions
        .as_array()
        .unwrap()
        .iter()
        .map(|r| (r["c"]["x"].as_f64().unwrap() - x).hypot(r["c"]["z"].as_f64().unwrap() - z))
        .fold(f64::INFINITY, f64::min);
    assert!(nearest <= 23.0, "{nearest} m: {:?}", hits[0]);

    // locate: a T-junction with what stands at it ranks a T-junction first, with evidence
    let l = json(&og(&[
        "locate",
        "--db",
        s(&db),
        "I'm at a T-junction, there's a traffic light nearby",
        "--json",
    ]));
    assert_eq!(l["description"]["segment"], "t_junction", "{l}");
    assert_eq!(l["results"][0]["kind"], "t_intersection", "{l}");
    assert!(
        !l["results"][0]["evidence"].as_array().unwrap().is_empty(),
        "{l}"
    );
    let e = json(&og(&[
        "eval",
        "locate",
        "--db",
        s(&db),
        "--sim",
        s(&sim),
        "--json",
    ]));
    assert!(e["all"]["cases"].as_u64().unwrap() >= 40, "{e}");
    // the goal is top-1 >= 0.8: measured 0.824 / 0.926 at seed 0 (0.706 / 0.838 before
    // small things were kept and chained junctions split), then 0.794 / 0.926 once association
    // stopped joining detections to far objects of the same caption (issue 31): the one spot
    // lost (two descriptions) names a hydrant seen once with 20 points, which had survived
    // only through such a far join. Below the goal, and said so in docs/build.md.
    assert!(e["all"]["top1"].as_f64().unwrap() >= 0.79, "{e}");
    assert!(e["all"]["top3"].as_f64().unwrap() >= 0.9, "{e}");
    // the first answer's position (issue 29: within 10 m for >= 0.8, within 5 m for >= 0.5):
    // measured 0.735 / 0.456 with the weighted mean over the segment, 0.662 / 0.324 when
    // the position was the best of the coarse standing spots. Below the goal; docs/find.md.
    assert!(e["within_10m"].as_f64().unwrap() >= 0.7, "{e}");
    assert!(e["within_5m"].as_f64().unwrap() >= 0.42, "{e}");

    // navigate: both ends from words; the route ends at the instance `find` resolved
    let png = dir.path().join("nav.png");
    let n = json(&og(&[
        "navigate",
        "--db",
        s(&db),
        "from the bus stop by the crossroads to somewhere I can post a letter",
        "--png",
        s(&png),
        "--json",
    ]));
    assert_eq!(n["start"]["by"], "find", "{n}");
    assert_eq!(n["goal"]["by"], "find", "{n}");
    let goal = n["goal"]["result"]["id"].as_u64().unwrap();
    assert_eq!(n["plan"]["to"]["node"].as_u64(), Some(goal), "{n}");
    assert!(
        n["goal"]["result"]["caption"]
            .as_str()
            .unwrap()
            .to_lowercase()
            .contains("box"),
        "{n}"
    );
    assert!(n["plan"]["route"]["length_m"].as_f64().unwrap() > 0.0);
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);
    // the path keeps to the drivable areas (within the planner's tolerance)
    assert!(n["plan"]["drivable_segments"].as_u64().unwrap() > 0, "{n}");
    {
        let store = graphstore::Store::open_read_only(&db).unwrap();
        let r = store.read().unwrap();
        let ground = scene::records::ground_frame(&r).unwrap();
        let areas = planner::motion::drivable_of_store(&r, ground).unwrap();
        let index = scene::area::DrivableIndex::new(&areas);
        let poses = n["plan"]["path"]["poses"].as_array().unwrap();
        let off: Vec<&serde_json::Value> = poses
            .iter()
            .filter(|p| {
                let q = [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()];
                !index.within(q, 0.5)
            })
            .collect();
        assert!(
            n["plan"]["path"]["fallback"] == true || off.is_empty(),
            "{} of {} poses off the drivable areas: {off:?}",
            off.len(),
            poses.len()
        );
    }
    // a place is located, not found
    let n = json(&og(&[
        "navigate",
        "--db",
        s(&db),
        "--from",
        "the bus stop",
        "--to",
        "the T-junction",
        "--json",
    ]));
    assert_eq!(n["goal"]["by"], "locate", "{n}");
    assert_eq!(n["plan"]["to"]["kind"], "Segment", "{n}");
    // no start: a usage error that says what to do
    let out = og(&["navigate", "--db", s(&db), "take me to a bench"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--from"));
}
