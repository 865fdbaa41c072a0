//! Time-boxed fuzz targets (`og-fuzz`; `OG_FUZZ_SECS=600 cargo test -p graphstore --test fuzz
//! -- --nocapture` runs each for ten minutes): the Cypher parser and executor on a small graph,
//! and the value codec. Any outcome but a panic is fine; a panicking input is saved under
//! `tests/fuzz-regressions/TARGET/` and replayed on every run once committed. The Cypher
//! target runs under a 256 MiB statement budget, counted by the allocator `opengraph` uses;
//! as a soak with the process capped at 4 GiB of address space:
//! `OG_FUZZ_SECS=600 prlimit --as=4294967296 cargo test --release -p graphstore --test fuzz -- --nocapture`.

use std::path::Path;
use std::time::Duration;

use graphstore::cypher::QueryOptions;
use graphstore::{Store, Value};

#[global_allocator]
static ALLOC: graphstore::mem::CountingAlloc = graphstore::mem::CountingAlloc;

fn regressions() -> &'static Path {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fuzz-regressions"
    ))
}

const QUERIES: &[&str] = &[
    "MATCH (a:Lane)-[:NEXT*1..3]->(b:Lane) WHERE b.x > a.x RETURN a.id, collect(b.id) AS next ORDER BY a.id",
    "MATCH (i:Instance) WHERE i.caption CONTAINS 'bench' AND i.score >= 0.5 RETURN i.caption, i.score LIMIT 3",
    "MATCH (i:Instance)-[:IN_SEGMENT]->(s:Segment {kind: 'crossroads'}) RETURN s.kind, count(*) AS n",
    "UNWIND range(1, 20) AS x WITH x, x % 3 AS k RETURN k, sum(x), avg(toFloat(x)), min(x), max(x)",
    "MATCH (n) OPTIONAL MATCH (n)-[r]->(m) RETURN labels(n), type(r), properties(m) SKIP 1 LIMIT 10",
    "MATCH p = shortestPath((a:Lane {id: 1})-[:NEXT*]->(b:Lane {id: 4})) RETURN length(p), nodes(p)",
    "RETURN 9223372036854775807 + 1, 1.0/0.0, 0.0/0.0, toInteger('12'), toFloat('x'), [1, 2][5]",
    "WITH point({x: 1, y: 2}) AS p RETURN p.x, distance(p, point({x: 4, y: 6}))",
    "MATCH (i:Instance) WITH i ORDER BY i.score DESC WITH collect(i)[0..2] AS top UNWIND top AS t RETURN t.caption",
    "CREATE (a:Tmp {v: [1, 2, 3], s: 'x'})-[:R {w: 0.5}]->(b:Tmp) SET a.k = 2 REMOVE a.s RETURN a, b",
    "MATCH (t:Tmp) DETACH DELETE t",
    "MERGE (n:Counter {k: 'c'}) ON CREATE SET n.v = 0 ON MATCH SET n.v = n.v + 1 RETURN n.v",
    "EXPLAIN MATCH (a)-[r]-(b) WHERE a.x = $x RETURN a, r, b",
    "CALL db.labels() YIELD label RETURN label ORDER BY label",
    "RETURN CASE WHEN $x IS NULL THEN [y IN range(0, 4) WHERE y % 2 = 0 | y * 2] ELSE reduce(s = 0, z IN [1, 2] | s + z) END",
    "MATCH (a:Lane) RETURN a.id =~ '1.*', a.id IN [1, 2], a.x STARTS WITH 'x', a {.id, .x}",
    "RETURN size(reduce(s = 'ab', i IN range(1, 30) | s + s)), split('a,b', ','), replace('aa', 'a', 'bb')",
    "CALL db.index.vector.queryNodes('v', 9223372036854775807, [0.1, 0.2]) YIELD node RETURN node",
    "MATCH p = (a)-[*]-(b) RETURN count(p), [x IN range(1, 100) | [y IN range(1, 100) | {k: y}]][0][0]",
];

fn small_graph(dir: &Path) -> Store {
    let s = Store::create(dir.join("fuzz.og")).expect("store");
    s.query(
        "CREATE (a:Lane {id: 1, x: 0.0})-[:NEXT]->(b:Lane {id: 2, x: 10.0})-[:NEXT]->(c:Lane {id: 3, x: 20.0})-[:NEXT]->(d:Lane {id: 4, x: 30.0}), \
         (s:Segment {kind: 'crossroads'}), (i:Instance {caption: 'a green bench', score: 0.8})-[:IN_SEGMENT]->(s), \
         (j:Instance {caption: 'a red car', score: 0.4})-[:IN_SEGMENT]->(s)",
        &QueryOptions::default(),
    )
    .expect("seed graph");
    s
}

#[test]
fn fuzz_cypher_parser_and_executor() {
    let dir = tempfile::tempdir().unwrap();
    let s = small_graph(dir.path());
    let seeds: Vec<Vec<u8>> = QUERIES.iter().map(|q| q.as_bytes().to_vec()).collect();
    let (mut n, mut ran) = (0u64, 0u64);
    og_fuzz::fuzz("cypher", &seeds, regressions(), |bytes| {
        let text = String::from_utf8_lossy(bytes);
        n += 1;
        let mut params = std::collections::BTreeMap::new();
        params.insert("x".to_string(), graphstore::cypher::Val::Int(1));
        let opts = QueryOptions {
            params,
            timeout: Some(Duration::from_millis(100)),
            row_limit: Some(1000),
            // writes too, now and then (they commit on this scratch store)
            read_only: !n.is_multiple_of(4),
            max_intermediate_rows: 100_000,
            max_memory_bytes: 256 << 20,
            ..QueryOptions::default()
        };
        if s.query(&text, &opts).is_ok() {
            ran += 1;
        }
    });
    eprintln!("fuzz cypher: {ran} of {n} inputs parsed and ran to a result");
    assert!(ran > 0);
    // the store is still whole
    assert!(s.check_consistency().unwrap().is_empty());
}

#[test]
fn fuzz_value_codec() {
    let values = [
        Value::Null,
        Value::Int(-7),
        Value::Float(2.5),
        Value::String("a bench\n".into()),
        Value::List(vec![
            Value::Int(1),
            Value::String("x".into()),
            Value::List(vec![]),
        ]),
        Value::Point3D([1.0, -2.0, 3.5]),
        Value::Vector(vec![0.1, 0.2, -0.3]),
        Value::Bytes(vec![0, 1, 255]),
    ];
    let seeds: Vec<Vec<u8>> = values.iter().map(Value::to_bytes).collect();
    og_fuzz::fuzz("value_codec", &seeds, regressions(), |bytes| {
        // a value that decodes encodes back to what decodes to the same value
        if let Ok(v) = Value::from_bytes(bytes) {
            let again = Value::from_bytes(&v.to_bytes()).expect("re-encoded value decodes");
            assert!(
                again == v || (!v.is_finite() && !again.is_finite()),
                "{v:?} != {again:?}"
            );
        }
    });
}
