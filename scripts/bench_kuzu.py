#!/usr/bin/env python3
"""opengraph's Cypher engine side by side with Kùzu (PyPI `kuzu`), in one run, ratio printed.

One synthetic scene-like graph (seeded): `Instance` nodes (class, score, x, y), `Segment`
nodes (name, kind), `IN_SEGMENT` (every instance to one segment), `CONNECTS` (segments in a
ring with random chords) and `NEAR` (random instance pairs) relationships, all with
`distance_m`. It is written once as CSV, loaded into both (opengraph: `opengraph import` of the
Neo4j bulk-import files; Kùzu: `COPY` into declared tables), and the same queries are timed in
each engine's own process: opengraph with `opengraph query --repeat N` (engine time of each run
after a first one), Kùzu in this process (`execute` plus fetching every row). Rows are compared
after rounding floats to 6 significant digits.

    scripts/bench_kuzu.py --opengraph target/release/opengraph                # 200k / 1M
    scripts/bench_kuzu.py --opengraph BIN --nodes 20000 --rels 100000 --runs 5  # quick

Needs `kuzu` (scripts/setup.sh installs it into the project's venv; without it the script
says so and exits 0). Prints a table and, with --json FILE, writes every figure.
"""

import argparse
import csv
import json
import os
import random
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

CLASSES = [
    "car", "person", "tree trunk", "vegetation", "building", "pole", "street lamp",
    "traffic sign", "bench", "trash can", "fire hydrant", "mailbox", "bicycle", "fence",
    "bus stop shelter", "traffic light", "truck", "motorcycle", "billboard", "other-vehicle",
]
KINDS = ["crossroad", "T-junction", "L-bend", "straight road"]


def generate(out, n_nodes, n_rels, seed):
    """Writes both engines' CSV files; returns what the queries need to know."""
    rng = random.Random(seed)
    n_seg = max(10, n_nodes // 20)
    n_inst = n_nodes - n_seg
    seg0 = n_inst  # global ids: instances 0.., segments after them
    os.makedirs(out, exist_ok=True)
    og = os.path.join(out, "og")
    kz = os.path.join(out, "kuzu")
    os.makedirs(og, exist_ok=True)
    os.makedirs(kz, exist_ok=True)

    def both(name, og_header, kz_header, rows):
        with open(os.path.join(og, name), "w", newline="") as f, open(
            os.path.join(kz, name), "w", newline=""
        ) as g:
            a, b = csv.writer(f), csv.writer(g)
            a.writerow(og_header)
            b.writerow(kz_header)
            for og_row, kz_row in rows:
                a.writerow(og_row)
                b.writerow(kz_row)

    def instances():
        for i in range(n_inst):
            c = CLASSES[min(int(rng.expovariate(0.25)), len(CLASSES) - 1)]
            s = round(rng.random(), 6)
            x, y = round(rng.uniform(0, 2000), 3), round(rng.uniform(0, 2000), 3)
            yield [i, c, s, x, y, "Instance"], [i, c, s, x, y]

    both(
        "nodes_Instance.csv",
        [":ID", "class:string", "score:double", "x:double", "y:double", ":LABEL"],
        ["id", "class", "score", "x", "y"],
        instances(),
    )

    def segments():
        for j in range(n_seg):
            k = KINDS[rng.randrange(len(KINDS))]
            yield [seg0 + j, f"seg{j}", k, "Segment"], [seg0 + j, f"seg{j}", k]

    both(
        "nodes_Segment.csv",
        [":ID", "name:string", "kind:string", ":LABEL"],
        ["id", "name", "kind"],
        segments(),
    )
    rel_header = [":START_ID", ":END_ID", ":TYPE", "distance_m:double"]
    kz_rel = ["from", "to", "distance_m"]

    def in_segment():
        for i in range(n_inst):
            s = seg0 + rng.randrange(n_seg)
            d = round(rng.expovariate(1.0), 4)
            yield [i, s, "IN_SEGMENT", d], [i, s, d]

    both("relationships_IN_SEGMENT.csv", rel_header, kz_rel, in_segment())
    n_conn = 0

    def connects():
        nonlocal n_conn
        for j in range(n_seg):
            for t in ((j + 1) % n_seg, rng.randrange(n_seg)):
                if t != j:
                    n_conn += 1
                    d = round(rng.uniform(20, 200), 3)
                    yield [seg0 + j, seg0 + t, "CONNECTS", d], [seg0 + j, seg0 + t, d]

    both("relationships_CONNECTS.csv", rel_header, kz_rel, connects())
    n_near = max(0, n_rels - n_inst - n_conn)

    def near():
        for _ in range(n_near):
            # no self-loops: Kùzu lets one relationship repeat inside a MATCH, openCypher
            # does not, so a self-loop would make the 2-hop counts differ by design
            a = rng.randrange(n_inst)
            b = (a + 1 + rng.randrange(n_inst - 1)) % n_inst
            d = round(rng.uniform(0, 30), 4)
            yield [a, b, "NEAR", d], [a, b, d]

    both("relationships_NEAR.csv", rel_header, kz_rel, near())
    return {
        "instances": n_inst,
        "segments": n_seg,
        "in_segment": n_inst,
        "connects": n_conn,
        "near": n_near,
        "og": og,
        "kuzu": kz,
    }


def queries(anchor):
    """(name, opengraph statement, Kùzu statement): the same question in each dialect."""
    a = f"seg{anchor}"
    same = [
        ("count Instance", "MATCH (n:Instance) RETURN count(*) AS n"),
        (
            "group by class, avg/max",
            "MATCH (n:Instance) RETURN n.class AS c, count(*) AS k, avg(n.score) AS a, "
            "max(n.score) AS m ORDER BY c",
        ),
        (
            "group over NEAR rels",
            "MATCH (a:Instance)-[r:NEAR]->(b:Instance) RETURN a.class AS c, count(*) AS k, "
            "avg(r.distance_m) AS d ORDER BY c",
        ),
        (
            "2-hop pattern count",
            "MATCH (a:Instance)-[:NEAR]->(b:Instance)-[:NEAR]->(c:Instance) RETURN count(*) AS n",
        ),
        (
            "top-10 rels by property",
            "MATCH (:Instance)-[r:NEAR]->(:Instance) RETURN r.distance_m AS d ORDER BY d DESC LIMIT 10",
        ),
        (
            "anchored 2-hop",
            f"MATCH (s:Segment {{name: '{a}'}})<-[:IN_SEGMENT]-(o:Instance)-[:NEAR]->(p:Instance) "
            "RETURN count(*) AS n",
        ),
        (
            "anchored 3-hop",
            f"MATCH (s:Segment {{name: '{a}'}})-[:CONNECTS]->(t:Segment)-[:CONNECTS]->(u:Segment)"
            "<-[:IN_SEGMENT]-(o:Instance) RETURN count(*) AS n",
        ),
        (
            "filter + aggregate",
            "MATCH (n:Instance) WHERE n.score > 0.99 RETURN n.class AS c, count(*) AS k ORDER BY c",
        ),
    ]
    out = [(n, q, q) for n, q in same]
    out.append(
        (
            "var-length CONNECTS*1..4",
            f"MATCH (s:Segment {{name: '{a}'}})-[:CONNECTS*1..4]->(t:Segment) "
            "RETURN count(DISTINCT t) AS n",
            f"MATCH (s:Segment {{name: '{a}'}})-[:CONNECTS* TRAIL 1..4]->(t:Segment) "
            "RETURN count(DISTINCT t) AS n",
        )
    )
    out.append(
        (
            "shortest path length",
            f"MATCH p = shortestPath((s:Segment {{name: '{a}'}})-[:CONNECTS*..30]->"
            "(t:Segment {name: 'seg1'})) RETURN length(p) AS n",
            f"MATCH p = (s:Segment {{name: '{a}'}})-[:CONNECTS* SHORTEST 1..30]->"
            "(t:Segment {name: 'seg1'}) RETURN length(p) AS n",
        )
    )
    return out


def norm(v):
    if isinstance(v, float):
        return float(f"{v:.6g}")
    if isinstance(v, list):
        return [norm(x) for x in v]
    return v


def pct(xs, q):
    xs = sorted(xs)
    return xs[round((len(xs) - 1) * q)]


def files_under(p):
    if os.path.isfile(p):
        return [p]
    return [os.path.join(r, f) for r, _, fs in os.walk(p) for f in fs]


def dir_size(p):
    """Apparent size in bytes (what `ls -l` shows; a sparse file counts its holes)."""
    return sum(os.path.getsize(f) for f in files_under(p))


def disk_usage(p):
    """Bytes of disk allocated (what `du` shows): redb grows its file by doubling it while
    it is smaller than one region, and the new tail is a hole until pages are written."""
    return sum(os.stat(f).st_blocks * 512 for f in files_under(p))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--opengraph", required=True, help="the opengraph binary (release)")
    ap.add_argument("--nodes", type=int, default=200_000)
    ap.add_argument("--rels", type=int, default=1_000_000)
    ap.add_argument("--runs", type=int, default=10, help="timed runs per query")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--load-runs",
        type=int,
        default=3,
        help="loads of the graph into each engine, alternating, each into a fresh store; "
        "the median is reported",
    )
    ap.add_argument(
        "--kuzu-threads", type=int, default=0,
        help="Kùzu's query threads (0: its default, every core); opengraph uses one",
    )
    ap.add_argument("--work", help="folder for the CSV files and stores (default: a temp dir)")
    ap.add_argument("--json", help="write every figure to this file")
    args = ap.parse_args()
    try:
        import kuzu
    except ImportError:
        print("skipping: no kuzu in this Python (run scripts/setup.sh, then use its venv)")
        return 0
    # a scratch folder: a new temporary one (removed at the end), or --work, which must be
    # empty or one this bench made before (it is cleared: the stores are written afresh)
    marker = ".og-kuzu-bench"
    work = args.work or tempfile.mkdtemp(prefix="og-kuzu-")
    if args.work and os.path.isdir(work) and os.listdir(work):
        if not os.path.exists(os.path.join(work, marker)):
            sys.exit(
                f"--work {work} is not empty and was not made by this bench: give an empty or new folder"
            )
    if os.path.exists(work):
        shutil.rmtree(work)
    os.makedirs(work)
    open(os.path.join(work, marker), "w").close()
    if not args.work:
        import atexit

        atexit.register(shutil.rmtree, work, True)
    t = time.perf_counter()
    g = generate(work, args.nodes, args.rels, args.seed)
    print(
        f"graph: {args.nodes} nodes ({g['instances']} Instance, {g['segments']} Segment), "
        f"{g['in_segment'] + g['connects'] + g['near']} relationships "
        f"(IN_SEGMENT {g['in_segment']}, CONNECTS {g['connects']}, NEAR {g['near']}); "
        f"CSV written in {time.perf_counter() - t:.1f} s to {work}",
        flush=True,
    )
    report = {"nodes": args.nodes, "graph": g, "kuzu_version": kuzu.__version__, "queries": []}

    # --- load ---
    # each engine loads the graph --load-runs times, alternating, into a fresh store (the last
    # one stays for the queries); the medians are compared
    og_db = os.path.join(work, "bench.og")
    kz_db = os.path.join(work, "bench.kuzu")
    og_loads, kz_loads = [], []
    for _ in range(max(1, args.load_runs)):
        for path in (og_db, kz_db):
            if os.path.isdir(path):
                shutil.rmtree(path)
            elif os.path.exists(path):
                os.remove(path)
        t = time.perf_counter()
        r = subprocess.run(
            [args.opengraph, "import", "--db", og_db, "--json", g["og"]],
            capture_output=True,
            text=True,
        )
        og_loads.append(time.perf_counter() - t)
        if r.returncode != 0:
            sys.exit(f"opengraph import failed: {r.stderr}")
        t = time.perf_counter()
        db = kuzu.Database(kz_db)
        conn = kuzu.Connection(db)
        conn.execute(
            "CREATE NODE TABLE Instance(id INT64, class STRING, score DOUBLE, x DOUBLE, "
            "y DOUBLE, PRIMARY KEY(id))"
        )
        conn.execute(
            "CREATE NODE TABLE Segment(id INT64, name STRING, kind STRING, PRIMARY KEY(id))"
        )
        conn.execute("CREATE REL TABLE IN_SEGMENT(FROM Instance TO Segment, distance_m DOUBLE)")
        conn.execute("CREATE REL TABLE CONNECTS(FROM Segment TO Segment, distance_m DOUBLE)")
        conn.execute("CREATE REL TABLE NEAR(FROM Instance TO Instance, distance_m DOUBLE)")
        for table, f in [
            ("Instance", "nodes_Instance.csv"),
            ("Segment", "nodes_Segment.csv"),
            ("IN_SEGMENT", "relationships_IN_SEGMENT.csv"),
            ("CONNECTS", "relationships_CONNECTS.csv"),
            ("NEAR", "relationships_NEAR.csv"),
        ]:
            conn.execute(f"COPY {table} FROM '{os.path.join(g['kuzu'], f)}' (HEADER=true)")
        kz_loads.append(time.perf_counter() - t)
        del conn, db
    og_load, kz_load = statistics.median(og_loads), statistics.median(kz_loads)
    # the anchored queries look a segment up by name: opengraph gets a property index on it;
    # Kùzu has no secondary index (its primary key is `id`), so it scans the segments
    t = time.perf_counter()
    r = subprocess.run(
        [args.opengraph, "query", "--db", og_db, "CREATE INDEX FOR (s:Segment) ON (s.name)"],
        capture_output=True,
        text=True,
    )
    og_index = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit(f"opengraph CREATE INDEX failed: {r.stderr}")
    og_size, kz_size = dir_size(og_db), dir_size(kz_db)
    og_disk, kz_disk = disk_usage(og_db), disk_usage(kz_db)
    print(
        f"load (median of {len(og_loads)}): opengraph import {og_load:.2f} s (whole process; "
        f"{', '.join(f'{x:.2f}' for x in og_loads)}), Kùzu COPY {kz_load:.2f} s (in process, "
        f"tables declared; {', '.join(f'{x:.2f}' for x in kz_loads)}) -> "
        f"{og_load / kz_load:.2f}x; opengraph CREATE INDEX "
        f"on Segment.name {og_index:.2f} s (Kùzu has no secondary index)",
        flush=True,
    )
    print(
        f"store size on disk (du): opengraph {og_disk / 1e6:.1f} MB, Kùzu "
        f"{kz_disk / 1e6:.1f} MB -> {og_disk / kz_disk:.2f}x; apparent size (ls -l): "
        f"opengraph {og_size / 1e6:.1f} MB, Kùzu {kz_size / 1e6:.1f} MB "
        f"-> {og_size / kz_size:.2f}x",
        flush=True,
    )
    report.update(
        og_load_secs=og_load,
        og_index_secs=og_index,
        kuzu_load_secs=kz_load,
        og_bytes=og_size,
        kuzu_bytes=kz_size,
        og_disk_bytes=og_disk,
        kuzu_disk_bytes=kz_disk,
    )
    t = time.perf_counter()
    db = kuzu.Database(kz_db, read_only=True)
    conn = kuzu.Connection(db) if args.kuzu_threads == 0 else kuzu.Connection(
        db, num_threads=args.kuzu_threads
    )
    kz_open = (time.perf_counter() - t) * 1e3
    report["kuzu_open_ms"] = kz_open

    # --- queries ---
    anchor = 17
    rows_out = []
    og_open = []
    for name, og_q, kz_q in queries(anchor):
        r = subprocess.run(
            [
                args.opengraph, "query", "--db", og_db, "--json", "--read-only",
                "--timeout-secs", "600", "--max-rows", "10000000",
                "--repeat", str(args.runs), og_q,
            ],
            capture_output=True,
            text=True,
        )
        og = {"error": None}
        if r.returncode != 0:
            og["error"] = (r.stderr.strip().splitlines() or ["?"])[-1]
        else:
            m = re.search(r"timing: (.*)", r.stderr)
            f = dict(kv.split("=") for kv in m.group(1).split())
            og.update(p50=float(f["p50_ms"]), p99=float(f["p99_ms"]))
            og_open.append(float(f["open_ms"]))
            og["rows"] = [
                {k: norm(v) for k, v in row.items()} for row in json.loads(r.stdout)
            ]
        kz = {"error": None}
        try:
            res = conn.execute(kz_q)
            cols = res.get_column_names()
            kz["rows"] = [
                {k: norm(v) for k, v in zip(cols, row)} for row in res.get_all()
            ]
            times = []
            for _ in range(args.runs):
                t = time.perf_counter()
                res = conn.execute(kz_q)
                res.get_all()
                times.append((time.perf_counter() - t) * 1e3)
            kz.update(p50=pct(times, 0.5), p99=pct(times, 0.99))
        except Exception as e:  # noqa: BLE001 - any engine error is reported, not fatal
            kz["error"] = str(e).splitlines()[0]
        same = (
            "-"
            if og["error"] or kz["error"]
            else ("yes" if og["rows"] == kz["rows"] else "NO")
        )
        if same == "NO":
            diff = next(
                (i for i, (x, y) in enumerate(zip(og["rows"], kz["rows"])) if x != y),
                min(len(og["rows"]), len(kz["rows"])),
            )
            at = lambda rows: rows[diff] if diff < len(rows) else "(no row)"  # noqa: E731
            og["differs"] = f"row {diff}: opengraph {at(og['rows'])}, Kùzu {at(kz['rows'])}"
        ratio = og["p50"] / kz["p50"] if "p50" in og and "p50" in kz else None
        rows_out.append((name, og, kz, same, ratio))
        report["queries"].append(
            {
                "name": name,
                "opengraph": {k: v for k, v in og.items() if k != "rows"},
                "kuzu": {k: v for k, v in kz.items() if k != "rows"},
                "rows_equal": same,
                "ratio_p50": ratio,
                "opengraph_statement": og_q,
                "kuzu_statement": kz_q,
            }
        )
        print(
            f"  {name}: opengraph "
            + (f"p50 {og['p50']:.2f} ms" if "p50" in og else f"error: {og['error']}")
            + ", Kùzu "
            + (f"p50 {kz['p50']:.2f} ms" if "p50" in kz else f"error: {kz['error']}")
            + (f" -> {ratio:.2f}x" if ratio else ""),
            flush=True,
        )
    og_open_ms = statistics.median(og_open) if og_open else None
    report["og_open_ms"] = og_open_ms

    print()
    print(f"{'query':28} {'og p50':>9} {'og p99':>9} {'kuzu p50':>9} {'kuzu p99':>9} "
          f"{'og/kuzu':>8}  rows")
    for name, og, kz, same, ratio in rows_out:
        def cell(d, k):
            return f"{d[k]:9.2f}" if k in d else f"{'error':>9}"
        print(
            f"{name:28} {cell(og, 'p50')} {cell(og, 'p99')} {cell(kz, 'p50')} {cell(kz, 'p99')} "
            f"{(f'{ratio:8.2f}' if ratio else '       -')}  {same}"
        )
    for name, og, kz, _, _ in rows_out:
        for who, d in (("opengraph", og), ("Kùzu", kz)):
            if d["error"]:
                print(f"  {name}: {who}: {d['error']}")
        if "differs" in og:
            print(f"  {name}: rows differ at {og['differs']}")
    print(
        f"open: opengraph {og_open_ms:.1f} ms (median over the query processes), "
        f"Kùzu {kz_open:.1f} ms"
        if og_open_ms is not None
        else ""
    )
    print(
        "times in ms; og/kuzu > 1 means opengraph is slower; Kùzu threads: "
        + (str(args.kuzu_threads) if args.kuzu_threads else "its default")
    )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
