"""Opt-in bench: a question fanned out over three region shards against the whole map.

Usage: python3 scripts/bench_shards.py BIN WORKDIR QUERIES.jsonl
  BIN      a release `opengraph` (cargo build --release -p api)
  WORKDIR  where the map is made (the default small city, MiniLM) unless WORKDIR/city.og is
           there, and cut into WORKDIR/shards
  QUERIES  a retrieval query set, e.g. ingest/eval/data/retrieval_small_city.jsonl

Serves the three regions and the whole map (as one region) from their own processes on
loopback and asks each query through `opengraph zenoh-query`: prints how many top-5 answers
are the same, the latency of both, and locate for four descriptions (docs/live.md)."""
import json, os, socket, subprocess, sys, time, statistics

bin_, work, qfile = sys.argv[1:4]
db = os.path.join(work, "city.og")
shards = os.path.join(work, "shards")

def run(args, timeout=600):
    p = subprocess.run([bin_] + args, capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0:
        raise SystemExit(f"{args} failed: {p.stderr}")
    return p.stdout

def port():
    s = socket.socket(); s.bind(("127.0.0.1", 0)); p = s.getsockname()[1]; s.close(); return p

if not os.path.exists(db):
    run(["sim", "--out", os.path.join(work, "sim"), "--size", "small", "--seed", "0"], timeout=1800)
    run(["build", "--kitti", os.path.join(work, "sim"), "--detections", os.path.join(work, "sim", "detections"), "--db", db], timeout=3600)
if not os.path.exists(shards):
    print(run(["shard", "--db", db, "--parts", "3", "--out", shards]))
ports = {r: port() for r in ["r1", "r2", "r3"]}
wp = port()
procs = []
for r, p in ports.items():
    procs.append(subprocess.Popen([bin_, "serve", "--db", f"{shards}/{r}.og", "--bind", "127.0.0.1:0", "--zenoh", "--no-live",
        "--map-name", "city", "--region", r, "--zenoh-listen", f"tcp/127.0.0.1:{p}"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
procs.append(subprocess.Popen([bin_, "serve", "--db", db, "--bind", "127.0.0.1:0", "--zenoh", "--no-live",
    "--map-name", "whole", "--region", "all", "--zenoh-listen", f"tcp/127.0.0.1:{wp}"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
time.sleep(8)
conn3 = sum([["--zenoh-connect", f"tcp/127.0.0.1:{p}"] for p in ports.values()], [])
conn1 = ["--zenoh-connect", f"tcp/127.0.0.1:{wp}"]
def fan(map_, tool, args, regions, conn):
    return json.loads(run(["zenoh-query", "--map", map_, tool, json.dumps(args), "--regions", regions, "--deadline-secs", "30"] + conn))
try:
    queries = [json.loads(l)["text"] for l in open(qfile) if l.strip() and not l.startswith("#")]
    same = 0; t3 = []; t1 = []; cross = 0
    for q in queries:
        a = {"text": q, "k": 5}
        f3 = fan("city", "find_objects", a, "r1,r2,r3", conn3)
        f1 = fan("whole", "find_objects", a, "all", conn1)
        assert not f3["missing"] and not f1["missing"], (f3["missing"], f1["missing"])
        r3 = [(r["id"], round(r["score"], 9)) for r in f3["answer"]["results"]]
        r1 = [(r["id"], round(r["score"], 9)) for r in f1["answer"]["results"]]
        same += r3 == r1
        if r3 != r1: print("differs:", q, r1, r3)
        t3.append(f3["time_ms"]); t1.append(f1["time_ms"])
    print(f"find: {same}/{len(queries)} queries give the same top 5 (ids and scores to 1e-9) over three regions as over the whole map")
    print(f"find latency (client-side, both passes), median / p90 ms: three regions {statistics.median(t3):.1f} / {sorted(t3)[int(0.9*len(t3))]:.1f}, "
          f"whole map as one region {statistics.median(t1):.1f} / {sorted(t1)[int(0.9*len(t1))]:.1f}, ratio {statistics.median(t3)/statistics.median(t1):.2f}")
    locs = ["I'm at a T-junction with a bus stop and a bench", "I'm at a crossroads next to a traffic light and a post box",
            "I'm on a straight road by a row of trees and a parked car", "I'm at a bend with a street lamp and a bin"]
    lsame = 0
    for d in locs:
        a = {"text": d, "k": 3}
        l3 = fan("city", "locate", a, "r1,r2,r3", conn3); l1 = fan("whole", "locate", a, "all", conn1)
        s3 = [r["segment"] for r in l3["answer"]["results"]]; s1 = [r["segment"] for r in l1["answer"]["results"]]
        lsame += s3[:1] == s1[:1]
        print(f"locate {d!r}: whole {s1} regions {s3}")
    print(f"locate: {lsame}/{len(locs)} descriptions give the same best segment")
finally:
    for p in procs: p.kill()
