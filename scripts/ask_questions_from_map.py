#!/usr/bin/env python3
"""Generates questions for `opengraph ask` from a built map, each with its truth computed by our
own Cypher on that map (never by the code under test), and splits them by the sha256 of the
text into a tuning half and a held-out half.

    scripts/ask_questions_from_map.py --db MAP --out DIR [--opengraph BIN] [--seed 0]

Kinds of question (the `kind` field): count, count_segments, count_within, count_near,
nearest, distance, route_length, segment, segment_kind, colour. Truth types (`truth`):
{"count": n}, {"id": node}, {"metres": d}, {"segment": id}, {"segment_kind": kind},
{"colour": c}. Kinds of object are given by hand-written label lists (what the words mean on
a street), not by the tools' WordNet matching. Writes DIR/ask_tune.jsonl and
DIR/ask_heldout.jsonl.
"""
import argparse
import hashlib
import heapq
import json
import math
import os
import random
import subprocess
import sys

# what the words of a kind mean on a street, by hand
KINDS = {
    "cars": ["car", "hatchback", "suv", "sedan", "saloon", "coupe", "estate car"],
    "post boxes": ["post box", "postbox", "letter box", "mailbox"],
    "mailboxes": ["post box", "postbox", "letter box", "mailbox"],
    "people": ["person", "man", "woman", "pedestrian", "child", "boy", "girl"],
    "pedestrians": ["person", "man", "woman", "pedestrian", "child", "boy", "girl"],
    "bins": ["bin", "rubbish bin", "litter bin", "trash can", "dustbin", "waste bin"],
    "trash cans": ["bin", "rubbish bin", "litter bin", "trash can", "dustbin", "waste bin"],
    "fire hydrants": ["fire hydrant", "hydrant"],
    "bus shelters": ["bus shelter"],
    "benches": ["bench"],
    "traffic lights": ["traffic light"],
    "buildings": ["building", "office building", "house"],
    "bicycles": ["bike", "bicycle"],
}
SINGULAR = {
    "cars": "car", "post boxes": "post box", "mailboxes": "mailbox", "people": "person",
    "pedestrians": "pedestrian", "bins": "bin", "trash cans": "trash can",
    "fire hydrants": "fire hydrant", "bus shelters": "bus shelter", "benches": "bench",
    "traffic lights": "traffic light", "buildings": "building", "bicycles": "bicycle",
}
SEGMENT_WORDS = {
    "intersection": ["crossroads", "four-way crossroads"],
    "t_intersection": ["T-junctions", "T-junction segments"],
    "l_intersection": ["bends", "L-bends"],
    "straight_roadway": ["straight roads", "straight road segments"],
}
SEGMENT_KIND_WORDS = {
    "intersection": "crossroads", "t_intersection": "t_junction",
    "l_intersection": "bend", "straight_roadway": "straight_road",
}


def query(binary, db, cypher):
    out = subprocess.run([binary, "query", "--db", db, "--json", cypher],
                         capture_output=True, text=True, check=True)
    v = json.loads(out.stdout)
    return v["rows"] if isinstance(v, dict) else v


def labels_in(labels):
    return "[" + ", ".join("'" + l.replace("'", "\\'") + "'" for l in labels) + "]"


def dijkstra(edges, a, b):
    adj = {}
    for (u, v, w) in edges:
        adj.setdefault(u, []).append((v, w))
        adj.setdefault(v, []).append((u, w))
    dist = {a: 0.0}
    heap = [(0.0, a)]
    while heap:
        d, u = heapq.heappop(heap)
        if u == b:
            return d
        if d > dist.get(u, math.inf):
            continue
        for v, w in adj.get(u, []):
            if d + w < dist.get(v, math.inf):
                dist[v] = d + w
                heapq.heappush(heap, (d + w, v))
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--db", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--opengraph", default=os.environ.get("OPENGRAPH_BIN", "opengraph"))
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    rng = random.Random(a.seed)
    q = lambda c: query(a.opengraph, a.db, c)
    out = []

    def add(kind, text, truth):
        out.append({"kind": kind, "question": text, "truth": truth})

    # counts of a kind on the whole map
    forms = ["How many {} are there?", "How many {} are on the map?", "Count the {}.",
             "How many {} does the map have?"]
    for words, labels in KINDS.items():
        n = q(f"MATCH (i:Instance) WHERE i.label IN {labels_in(labels)} RETURN count(i) AS n")[0]["n"]
        add("count", rng.choice(forms).format(words), {"count": n})
    # segments of a kind
    for kind, words in SEGMENT_WORDS.items():
        n = q(f"MATCH (s:Segment {{kind: '{kind}'}}) RETURN count(s) AS n")[0]["n"]
        for w in words:
            add("count_segments", rng.choice(["How many {} are there?", "How many {} does the map have?"]).format(w), {"count": n})
    n = q("MATCH (s:Segment) RETURN count(s) AS n")[0]["n"]
    add("count_segments", "How many road segments are there?", {"count": n})
    # a kind in one segment (by IN_SEGMENT)
    rows = q("MATCH (i:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE i.label IS NOT NULL "
             "RETURN id(s) AS s, i.label AS label, count(i) AS n ORDER BY s, label")
    by_label = {}
    for words, labels in KINDS.items():
        for l in labels:
            by_label.setdefault(l, words)
    seg_counts = {}
    for r in rows:
        words = by_label.get(r["label"])
        if words:
            seg_counts[(r["s"], words)] = seg_counts.get((r["s"], words), 0) + r["n"]
    picks = sorted(seg_counts.items())
    rng.shuffle(picks)
    for (s, words), n in picks[:6]:
        add("count_within", f"How many {words} are there in segment:{s}?", {"count": n})
    # a kind near the start of the drive
    start = q("MATCH (f:Frame) WITH f ORDER BY f.index LIMIT 1 "
              "RETURN f.world_from_velo[3] AS x, f.world_from_velo[11] AS z")[0]
    end = q("MATCH (f:Frame) WITH f ORDER BY f.index DESC LIMIT 1 "
            "RETURN f.world_from_velo[3] AS x, f.world_from_velo[11] AS z")[0]
    for words in ["cars", "benches", "people", "buildings"]:
        r = rng.choice([20, 30, 50])
        n = q(f"MATCH (i:Instance) WHERE i.label IN {labels_in(KINDS[words])} "
              f"AND sqrt((i.centroid.x - ({start['x']})) ^ 2 + (i.centroid.z - ({start['z']})) ^ 2) <= {r} "
              "RETURN count(i) AS n")[0]["n"]
        add("count_near", f"How many {words} are within {r} m of the start of the drive?", {"count": n})
    # the nearest of a kind to a place
    places = [("the start of the drive", start), ("the end of the drive", end)]
    segs = q("MATCH (s:Segment) RETURN id(s) AS id, s.centroid.x AS x, s.centroid.z AS z ORDER BY id")
    for s in rng.sample(segs, min(3, len(segs))):
        places.append((f"segment:{s['id']}", s))
    kinds = ["post boxes", "fire hydrants", "benches", "bus shelters", "bins", "traffic lights",
             "cars", "bicycles"]
    for i, (place, p) in enumerate(places):
        for words in rng.sample(kinds, 2):
            rows = q(f"MATCH (i:Instance) WHERE i.label IN {labels_in(KINDS[words])} "
                     f"WITH i, sqrt((i.centroid.x - ({p['x']})) ^ 2 + (i.centroid.z - ({p['z']})) ^ 2) AS d "
                     "RETURN id(i) AS id, d ORDER BY d, id LIMIT 2")
            if not rows or (len(rows) > 1 and rows[1]["d"] - rows[0]["d"] < 0.5):
                continue  # none, or a tie too close to call
            form = rng.choice(["What is the nearest {} to {}?", "Which {} is closest to {}?",
                               "Where is the nearest {} to {}?"])
            add("nearest", form.format(SINGULAR[words], place), {"id": rows[0]["id"]})
    # distances between two instances, and from a unique object to the start of the drive
    inst = q("MATCH (i:Instance) WHERE i.label IS NOT NULL RETURN id(i) AS id, "
             "i.centroid.x AS x, i.centroid.z AS z, i.label AS label, i.colour AS colour ORDER BY id")
    for _ in range(6):
        x, y = rng.sample(inst, 2)
        d = math.hypot(x["x"] - y["x"], x["z"] - y["z"])
        form = rng.choice(["How far is instance:{} from instance:{}?",
                           "What is the distance between instance:{} and instance:{}?"])
        add("distance", form.format(x["id"], y["id"]), {"metres": d})
    counts = {}
    for i in inst:
        counts[i["label"]] = counts.get(i["label"], 0) + 1
    uniques = [i for i in inst if counts[i["label"]] == 1 and i["label"] not in ("bush",)]
    by_colour = {}
    for i in inst:
        if i["colour"]:
            by_colour.setdefault((i["colour"], i["label"]), []).append(i)
    coloured = [v[0] for (c, l), v in sorted(by_colour.items()) if len(v) == 1 and counts[l] > 1]
    named = [(f"the {i['label']}", i) for i in uniques] + \
        [(f"the {i['colour']} {i['label']}", i) for i in rng.sample(coloured, min(8, len(coloured)))]
    for name, i in named[:4]:
        d = math.hypot(i["x"] - start["x"], i["z"] - start["z"])
        add("distance", f"How far is {name} from the start of the drive?", {"metres": d})
    # route lengths between lane nodes (Dijkstra over LANE, undirected, by length_m)
    lanes = q("MATCH (a:LaneNode)-[r:LANE]->(b:LaneNode) RETURN id(a) AS a, id(b) AS b, r.length_m AS w")
    edges = [(r["a"], r["b"], r["w"]) for r in lanes]
    nodes = sorted({e[0] for e in edges} | {e[1] for e in edges})
    for _ in range(6):
        u, v = rng.sample(nodes, 2)
        d = dijkstra(edges, u, v)
        if d is None:
            continue
        form = rng.choice(["How long is the route from lane:{} to lane:{}?",
                           "What is the driving distance from lane:{} to lane:{}?"])
        add("route_length", form.format(u, v), {"metres": d})
    # segments and colours of named objects
    segof = {r["i"]: (r["s"], r["k"]) for r in q(
        "MATCH (i:Instance)-[:IN_SEGMENT]->(s:Segment) RETURN id(i) AS i, id(s) AS s, s.kind AS k")}
    for name, i in named:
        if i["id"] not in segof:
            continue
        s, k = segof[i["id"]]
        if rng.random() < 0.5:
            add("segment", f"Which segment is {name} in?", {"segment": s})
        else:
            add("segment_kind", f"What kind of junction is {name} at?", {"segment_kind": SEGMENT_KIND_WORDS[k]})
    for name, i in named:
        if i["colour"] and not name.startswith(f"the {i['colour']} "):
            add("colour", f"What colour is {name}?", {"colour": i["colour"]})
    os.makedirs(a.out, exist_ok=True)
    halves = {"tune": [], "heldout": []}
    for item in out:
        h = hashlib.sha256(item["question"].encode()).digest()[0]
        halves["tune" if h % 2 == 0 else "heldout"].append(item)
    for name, items in halves.items():
        with open(os.path.join(a.out, f"ask_{name}.jsonl"), "w") as f:
            for item in items:
                f.write(json.dumps(item, sort_keys=True) + "\n")
    kinds = {}
    for item in out:
        kinds[item["kind"]] = kinds.get(item["kind"], 0) + 1
    print(json.dumps({"questions": len(out), "tune": len(halves["tune"]),
                      "heldout": len(halves["heldout"]), "per_kind": kinds}, sort_keys=True))


if __name__ == "__main__":
    sys.exit(main())
