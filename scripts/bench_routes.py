#!/usr/bin/env python3
"""Route + OMPL over random lane-node pairs of a built map, as `opengraph plan` runs them.

Picks `--routes` ordered pairs of distinct LaneNodes with a seeded RNG, runs
`opengraph plan --db MAP --from lane:A --to lane:B --json` for each (the default 200 ms OMPL
budget, 5 m turning radius, 6 m corridor), and prints the in-process time (the answer's
`timings_ms`: A* route, and route + OMPL) at p50 / p99, the route lengths, and how many paths
fell back to the route polyline. Pairs with no route are counted apart.

    python3 scripts/bench_routes.py --opengraph target/release/opengraph --db city.og
"""

import argparse
import json
import random
import subprocess
import sys
import time


def pct(xs, q):
    xs = sorted(xs)
    return xs[round((len(xs) - 1) * q)] if xs else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--opengraph", required=True, help="the opengraph binary (a release build)")
    ap.add_argument("--db", required=True, help="a built map")
    ap.add_argument("--routes", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budget-ms", type=float, help="OMPL budget (default: plan's, 200 ms)")
    ap.add_argument("--json", help="write every route's figures here")
    args = ap.parse_args()

    r = subprocess.run(
        [args.opengraph, "query", "--db", args.db, "--read-only", "--json",
         "MATCH (l:LaneNode) RETURN id(l) AS id ORDER BY id"],
        capture_output=True, text=True,
    )
    if r.returncode != 0:
        sys.exit(f"listing the lane nodes failed: {r.stderr.strip()}")
    lanes = [row["id"] for row in json.loads(r.stdout)]
    if len(lanes) < 2:
        sys.exit(f"{args.db} has {len(lanes)} lane nodes; a route needs two")
    rng = random.Random(args.seed)
    pairs = [tuple(rng.sample(lanes, 2)) for _ in range(args.routes)]

    rows, no_route = [], []
    t0 = time.perf_counter()
    for a, b in pairs:
        r = subprocess.run(
            [args.opengraph, "plan", "--db", args.db, "--from", f"lane:{a}", "--to",
             f"lane:{b}", "--json"]
            + (["--budget-ms", str(args.budget_ms)] if args.budget_ms is not None else []),
            capture_output=True, text=True,
        )
        if r.returncode != 0:
            no_route.append({"from": a, "to": b, "error": r.stderr.strip()[-300:]})
            continue
        d = json.loads(r.stdout)
        rows.append({
            "from": a, "to": b,
            "route_ms": d["timings_ms"][0], "plan_ms": d["timings_ms"][1],
            "length_m": d["route"]["length_m"],
            "fallback": bool(d["path"].get("fallback")),
            "warning": d["path"].get("warning"),
        })
    wall = time.perf_counter() - t0

    fallbacks = sum(r["fallback"] for r in rows)
    warned = sum(1 for r in rows if r["warning"])
    print(f"{args.db}: {len(lanes)} lane nodes; {len(pairs)} random ordered pairs (seed {args.seed}); "
          f"OMPL budget {args.budget_ms or 200:g} ms; "
          f"{len(rows)} planned, {len(no_route)} without a route; {wall:.0f} s in all")
    if rows:
        route = [r["route_ms"] for r in rows]
        plan = [r["plan_ms"] for r in rows]
        length = [r["length_m"] for r in rows]
        print(f"  A* route:        p50 {pct(route, 0.5):.1f} ms, p99 {pct(route, 0.99):.1f} ms")
        print(f"  route + OMPL:    p50 {pct(plan, 0.5):.1f} ms, p99 {pct(plan, 0.99):.1f} ms")
        print(f"  route length:    p50 {pct(length, 0.5):.0f} m, max {max(length):.0f} m")
        print(f"  fallbacks to the route polyline: {fallbacks} of {len(rows)} "
              f"({100 * fallbacks / len(rows):.1f} %); planned in the corridor alone "
              f"(drivable areas with gaps): {warned}")
    for e in no_route[:5]:
        print(f"  no route {e['from']} -> {e['to']}: {e['error']}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"routes": rows, "no_route": no_route}, f, indent=1)


if __name__ == "__main__":
    main()
