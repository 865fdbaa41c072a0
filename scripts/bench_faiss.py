#!/usr/bin/env python3
"""opengraph's exact vector top-k side by side with faiss (PyPI `faiss-cpu`), in one run.

The same seeded 384-d vectors (clustered like sentence embeddings: 200 centres plus noise, and
uniform random) go into both: into an opengraph store through `opengraph import` (a Neo4j
bulk-import file with a `float[]` column) and `CREATE VECTOR INDEX`, and into a faiss
`IndexFlatIP` over the L2-normalised vectors (exact cosine). Each query vector is timed in each
engine's own process on one core: opengraph with `opengraph query --repeat N` running
`CALL db.index.vector.queryNodes(..., 10, $q)` (engine time, Cypher included), faiss with
`search` on one vector at a time with `faiss.omp_set_num_threads(1)`. The top-10 ids are
compared for every query. Prints p50 and p99 per engine and the ratio.

    scripts/bench_faiss.py --opengraph target/release/opengraph                 # 100k x 384
    scripts/bench_faiss.py --opengraph BIN --vectors 20000 --queries 10         # quick

Needs numpy and faiss-cpu (installs faiss-cpu==1.15.1 with pip into this Python when it is
missing; says so and exits 0 when it cannot).
"""

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

from peer import need

FAISS = "faiss-cpu==1.15.1"


def need_faiss():
    return need("faiss", FAISS)


def vectors(np, kind, n, dim, seed):
    rng = np.random.default_rng(seed)
    if kind == "clustered":
        centres = rng.uniform(-1, 1, size=(200, dim)).astype(np.float32)
        pick = rng.integers(0, 200, size=n)
        return (centres[pick] + 0.35 * rng.uniform(-1, 1, size=(n, dim))).astype(np.float32)
    return rng.uniform(-1, 1, size=(n, dim)).astype(np.float32)


def pct(xs, p):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(p * (len(xs) - 1))))]


def run_kind(args, np, faiss, kind, work):
    n, dim = args.vectors, args.dim
    data = vectors(np, kind, n, dim, args.seed)
    queries = vectors(np, kind, args.queries, dim, args.seed + 1)
    # --- opengraph: import, then the vector index ---
    csv_path = os.path.join(work, f"nodes_{kind}.csv")
    t = time.perf_counter()
    with open(csv_path, "w") as f:
        f.write(":ID,e:float[]\n")
        for i, row in enumerate(data):
            f.write(f"{i}," + ";".join(f"{x:.7g}" for x in row.tolist()) + "\n")
    csv_secs = time.perf_counter() - t
    db = os.path.join(work, f"{kind}.og")
    t = time.perf_counter()
    r = subprocess.run(
        [args.opengraph, "import", "--db", db, "--nodes", f"Doc={csv_path}"],
        capture_output=True,
        text=True,
    )
    if r.returncode != 0:
        sys.exit(f"opengraph import failed: {r.stderr}")
    r = subprocess.run(
        [
            args.opengraph, "query", "--db", db,
            "CREATE VECTOR INDEX doc_e FOR (d:Doc) ON d.e OPTIONS "
            f"{{indexConfig: {{`vector.dimensions`: {dim}, `vector.similarity_function`: 'cosine'}}}}",
        ],
        capture_output=True,
        text=True,
    )
    if r.returncode != 0:
        sys.exit(f"opengraph CREATE VECTOR INDEX failed: {r.stderr}")
    og_load = time.perf_counter() - t
    os.remove(csv_path)
    # --- faiss: exact inner product over normalised rows = cosine ---
    faiss.omp_set_num_threads(1)
    t = time.perf_counter()
    unit = data / np.linalg.norm(data, axis=1, keepdims=True)
    index = faiss.IndexFlatIP(dim)
    index.add(unit)
    fa_load = time.perf_counter() - t
    og_p50s, og_p99s, fa_times, same = [], [], [], 0
    for qi, q in enumerate(queries):
        text = (
            "CALL db.index.vector.queryNodes('doc_e', 10, $q) YIELD node, score "
            "RETURN id(node) AS id, score ORDER BY score DESC, id"
        )
        r = subprocess.run(
            [
                args.opengraph, "query", "--db", db, "--read-only", "--json",
                "--repeat", str(args.runs), "--param", "q=" + json.dumps(q.tolist()), text,
            ],
            capture_output=True,
            text=True,
        )
        if r.returncode != 0:
            sys.exit(f"opengraph query failed: {r.stderr}")
        m = re.search(r"p50_ms=([\d.]+) p99_ms=([\d.]+)", r.stderr)
        if not m:
            sys.exit(f"no timing in opengraph's output: {r.stderr}")
        og_p50s.append(float(m.group(1)))
        og_p99s.append(float(m.group(2)))
        og_ids = [row["id"] for row in json.loads(r.stdout)]
        qn = (q / np.linalg.norm(q)).reshape(1, -1).astype(np.float32)
        index.search(qn, 10)  # warm-up
        for _ in range(args.runs):
            t = time.perf_counter()
            _, ids = index.search(qn, 10)
            fa_times.append((time.perf_counter() - t) * 1e3)
        if sorted(og_ids) == sorted(ids[0].tolist()):
            same += 1
        elif args.verbose:
            print(f"  query {qi}: opengraph {og_ids} faiss {ids[0].tolist()}")
    return {
        "kind": kind,
        "vectors": n,
        "dim": dim,
        "queries": len(queries),
        "csv_secs": csv_secs,
        "opengraph_load_secs": og_load,
        "faiss_load_secs": fa_load,
        # per query: p50 over its runs; the figure is the median of those, p99 the worst p99
        "opengraph_p50_ms": statistics.median(og_p50s),
        "opengraph_p99_ms": max(og_p99s),
        "faiss_p50_ms": pct(fa_times, 0.5),
        "faiss_p99_ms": pct(fa_times, 0.99),
        "same_top10": same,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--opengraph", required=True, help="the opengraph binary (a release build)")
    ap.add_argument("--vectors", type=int, default=100_000)
    ap.add_argument("--dim", type=int, default=384)
    ap.add_argument("--queries", type=int, default=20)
    ap.add_argument("--runs", type=int, default=10, help="timed runs per query and engine")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--kinds", default="clustered,uniform")
    ap.add_argument("--work", help="scratch folder (default: a new temporary one, removed)")
    ap.add_argument("--json", help="write every figure here")
    ap.add_argument("--verbose", action="store_true")
    args = ap.parse_args()
    try:
        import numpy as np
    except ImportError:
        print("skipping: no numpy in this Python (run scripts/setup.sh, then use its venv)")
        return 0
    if not need_faiss():
        print(f"skipping: {FAISS} could not be installed into {sys.executable}")
        return 0
    import faiss

    work = args.work or tempfile.mkdtemp(prefix="og-faiss-")
    os.makedirs(work, exist_ok=True)
    report = {"faiss_version": faiss.__version__, "results": []}
    try:
        for kind in args.kinds.split(","):
            res = run_kind(args, np, faiss, kind, work)
            report["results"].append(res)
            print(
                f"{kind}: {res['vectors']} x {res['dim']}; load opengraph {res['opengraph_load_secs']:.1f} s "
                f"(import + CREATE VECTOR INDEX), faiss {res['faiss_load_secs']:.2f} s; "
                f"top-10 equal for {res['same_top10']}/{res['queries']} queries",
                flush=True,
            )
    finally:
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)
    print()
    print(f"{'vectors':<12}{'og p50':>9}{'og p99':>9}{'faiss p50':>11}{'faiss p99':>11}{'og/faiss':>10}  top-10 equal")
    for r in report["results"]:
        print(
            f"{r['kind']:<12}{r['opengraph_p50_ms']:>9.2f}{r['opengraph_p99_ms']:>9.2f}"
            f"{r['faiss_p50_ms']:>11.2f}{r['faiss_p99_ms']:>11.2f}"
            f"{r['opengraph_p50_ms'] / r['faiss_p50_ms']:>10.2f}  {r['same_top10']}/{r['queries']}"
        )
    print(
        f"times in ms, one core each (faiss {report['faiss_version']} IndexFlatIP, "
        "opengraph engine time with Cypher); og/faiss > 1 means opengraph is slower"
    )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
