#!/usr/bin/env python3
"""Served latency of find, locate and a 2-hop Cypher count on a built map, one client.

Starts `opengraph serve --db MAP --bind 127.0.0.1:0 --read-only --embedding-cache 0
--query-cache 0` (no cache can answer a repeated request), waits for its address, then posts
sequentially: 12 find requests x `--rounds` to `/api/find`, 8 place descriptions x `--rounds`
to `/api/locate`, and `--cypher-runs` runs of the T-junction -> IN_SEGMENT -> RELATED count to
`/api/cypher`, and prints p50, p90 and max of each request's wall time (client side,
`time.perf_counter`, HTTP included). For the load test with many clients and a writer, see
`cargo bench -p api --bench load`.

    python3 scripts/bench_served.py --opengraph target/release/opengraph --db city.og
"""

import argparse
import json
import re
import statistics
import subprocess
import sys
import time
import urllib.request

FINDS = [
    "the post box next to the bus stop", "a red car", "a fire hydrant by the crossroads",
    "somewhere to sit", "the tree next to the street lamp", "a bicycle", "a bus stop shelter",
    "a traffic light at a T-junction", "a bench near a bus stop", "a yellow post box",
    "the trash can", "a parked truck",
]
PLACES = [
    "I'm at a T-junction next to a bus stop", "I'm at a crossroads with traffic lights",
    "I'm on a straight road by a bench", "I'm at a bend next to a post box",
    "I'm at a crossroads near a fire hydrant", "I'm on a straight road with parked cars",
    "I'm at a T-junction by a tree", "I'm near a bus stop shelter",
]
TWO_HOP = ("MATCH (s:Segment {kind:'t_intersection'})<-[:IN_SEGMENT]-(i:Instance)"
           "-[:RELATED]-(j:Instance) RETURN count(*) AS n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--opengraph", required=True, help="the opengraph binary (a release build)")
    ap.add_argument("--db", required=True, help="a built map")
    ap.add_argument("--rounds", type=int, default=3, help="times each find and locate text is sent")
    ap.add_argument("--cypher-runs", type=int, default=30)
    args = ap.parse_args()

    server = subprocess.Popen(
        [args.opengraph, "serve", "--db", args.db, "--bind", "127.0.0.1:0", "--read-only",
         "--embedding-cache", "0", "--query-cache", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        t0 = time.perf_counter()
        line = server.stdout.readline()
        found = re.search(r"http://[0-9.]+:[0-9]+", line)
        if not found:
            sys.exit(f"serve did not print its address: {line!r}")
        url = found.group(0)
        print(f"{args.db}: server up in {time.perf_counter() - t0:.2f} s at {url}")

        def post(path, body):
            req = urllib.request.Request(url + path, data=json.dumps(body).encode(),
                                         headers={"content-type": "application/json"})
            t = time.perf_counter()
            with urllib.request.urlopen(req, timeout=60) as r:
                r.read()
            return (time.perf_counter() - t) * 1e3

        for name, path, bodies in [
            ("find", "/api/find", [{"text": t} for t in FINDS] * args.rounds),
            ("locate", "/api/locate", [{"text": t} for t in PLACES] * args.rounds),
            ("2-hop Cypher", "/api/cypher", [{"query": TWO_HOP}] * args.cypher_runs),
        ]:
            ms = sorted(post(path, b) for b in bodies)
            print(f"  {name:13s} {len(ms):3d} requests: p50 {statistics.median(ms):.1f} ms, "
                  f"p90 {ms[int(len(ms) * 0.9)]:.1f} ms, max {ms[-1]:.1f} ms")
    finally:
        server.terminate()
        server.wait(timeout=10)


if __name__ == "__main__":
    main()
