#!/usr/bin/env python3
"""Scores `opengraph ask` on a question file made by scripts/ask_questions_from_map.py (the
same map): each answer's value against the truth our own Cypher computed, per kind of
question, with the median time per question (wall, one CLI run each: process start, model
load and the answer) and the median time inside `ask` (reading the question and running the
task, as a server that keeps the model loaded spends it).

    scripts/eval_ask.py --db MAP --questions FILE [--opengraph BIN] [--json] [-- ASK_ARGS...]

ASK_ARGS go to `opengraph ask` (e.g. `--llm none`, or `--llm local --llm-model PATH`).
A distance is right within 0.5 m or 1 %, whichever is more.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

KIND_WORDS = {"intersection": "crossroads", "t_intersection": "t_junction",
              "l_intersection": "bend", "straight_roadway": "straight_road"}


def normalise(kind, truth):
    """One truth form for every set: set 6 writes {"id"} for a segment, {"kind"} for a segment
    kind and {"distance_m"} / {"length_m"} for metres."""
    truth = dict(truth)
    if kind == "segment" and "id" in truth:
        truth = {"segment": truth["id"]}
    if kind == "segment_kind" and "kind" in truth:
        truth = {"segment_kind": truth["kind"]}
    for k in ("distance_m", "length_m"):
        if k in truth:
            truth = {"metres": truth[k]}
    return truth


def right(value, truth):
    if value is None:
        return False
    if "count" in truth:
        return isinstance(value, int) and value == truth["count"]
    if "id" in truth:
        return value == truth["id"]
    if "metres" in truth:
        t = truth["metres"]
        return isinstance(value, (int, float)) and abs(value - t) <= max(0.5, 0.01 * t)
    if "segment" in truth:
        return isinstance(value, dict) and value.get("id") == truth["segment"]
    if "segment_kind" in truth:
        return isinstance(value, dict) and KIND_WORDS.get(value.get("kind")) == truth["segment_kind"]
    if "colour" in truth:
        return value == truth["colour"]
    return False


def main():
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--db", required=True)
    ap.add_argument("--questions", required=True)
    ap.add_argument("--opengraph", default=os.environ.get("OPENGRAPH_BIN", "opengraph"))
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    items = [json.loads(l) for l in open(a.questions) if l.strip()]
    per_kind = {}
    times, rows = [], []
    for it in items:
        t0 = time.monotonic()
        p = subprocess.run([a.opengraph, "ask", "--db", a.db, "--json", it["question"], *extra],
                           capture_output=True, text=True)
        secs = time.monotonic() - t0
        times.append(secs)
        ans = json.loads(p.stdout) if p.returncode == 0 and p.stdout.strip() else {}
        ok = right(ans.get("value"), normalise(it["kind"], it["truth"]))
        k = per_kind.setdefault(it["kind"], [0, 0])
        k[0] += ok
        k[1] += 1
        rows.append({"question": it["question"], "kind": it["kind"], "right": ok,
                     "truth": it["truth"], "value": ans.get("value"), "task": ans.get("task"),
                     "model": ans.get("model"), "answer": ans.get("answer"),
                     "stopped": ans.get("stopped") or (p.stderr.strip()[-300:] if p.returncode else None),
                     "secs": round(secs, 2), "timings_ms": ans.get("timings_ms")})
    n_right = sum(v[0] for v in per_kind.values())
    report = {
        "questions": len(items),
        "right": n_right,
        "accuracy": n_right / max(1, len(items)),
        "per_kind": {k: {"right": v[0], "of": v[1], "accuracy": v[0] / v[1]}
                     for k, v in sorted(per_kind.items())},
        "median_secs": statistics.median(times) if times else None,
        # inside ask: reading the question (the model) and running the task, without the
        # process start and model load of each CLI run
        "median_ask_ms": statistics.median([sum(r["timings_ms"]) for r in rows if r["timings_ms"]])
        if any(r["timings_ms"] for r in rows) else None,
        "model": next((r["model"] for r in rows if r["model"]), None),
    }
    if a.json:
        print(json.dumps({"report": report, "rows": rows}, indent=1, sort_keys=True))
    else:
        for r in rows:
            if not r["right"]:
                print(f"WRONG [{r['kind']}] {r['question']}\n  truth {r['truth']} value {r['value']} "
                      f"task {r['task']} stopped {r['stopped']}")
        print(json.dumps(report, indent=1, sort_keys=True))


if __name__ == "__main__":
    sys.exit(main())
