#!/usr/bin/env python3
"""Held-out question set 6: spec, truth recomputation and audits.

Usage:
  python3 gen.py           # re-run every cypher, recompute truths, run audits, compare with questions.jsonl
  python3 gen.py --write   # same, then (re)write questions.jsonl from the spec (only if everything passes)

Environment:
  OPENGRAPH          the opengraph CLI (default /tmp/opengraph_old)
  OPENGRAPH_ASK_DB   the map store   (default /work/main/out/city.og)

Every query is run with --read-only.
"""
import heapq
import json
import math
import os
import re
import subprocess
import sys
from collections import Counter, defaultdict

OG = os.environ.get("OPENGRAPH", "/tmp/opengraph_old")
DB = os.environ.get("OPENGRAPH_ASK_DB", "/work/main/out/city.og")
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "questions.jsonl")

KIND_MAP = {"intersection": "crossroads", "t_intersection": "t_junction",
            "l_intersection": "bend", "straight_roadway": "straight_road"}
NEAR_MARGIN_M = 1.0      # no object of the kind within this of the radius
NEAREST_GAP_M = 0.5      # second nearest at least this much farther

# ---------------------------------------------------------------- vocabulary
# Kinds that are counted / searched for. regex = how a caption (or label) names the kind,
# read broadly (synonyms included).
KINDS = {
    "hydrant":          r"hydrant",
    "letter box":       r"post ?box|letter ?box|mail ?box",
    "rubbish bin":      r"\bbins?\b|trash|rubbish|litter|garbage|dustbin|waste",
    "traffic light":    r"traffic (light|signal)",
    "speed limit sign": r"speed limit",
    "trailer":          r"trailer",
    "hatchback":        r"hatchback",
}
# Nouns used in descriptions of single objects (broad readings).
NOUNS = {
    "scooter":        r"scooter",
    "post box":       r"post ?box|letter ?box|mail ?box",
    "hydrant":        r"hydrant",
    "traffic light":  r"traffic (light|signal)",
    "hatchback":      r"hatchback",
    "minibus":        r"minibus",
    "camper van":     r"camper|motorhome|\bvan\b",
    "suv":            r"\bsuv\b",
    "sedan":          r"sedan|saloon",
    "motorbike":      r"motorbike|motorcycle",
    "speed limit sign": r"speed limit",
    "delivery truck": r"truck|lorry",
    "climbing frame": r"climbing frame|playground|play area",
}
COLOURS = ["red", "blue", "green", "yellow", "white", "black", "grey", "gray", "silver",
           "beige", "orange", "brown", "pink", "purple"]

# ---------------------------------------------------------------- cypher builders
def dist(a, b):
    return f"sqrt(({a}.x - {b}.x)^2 + ({a}.z - {b}.z)^2)"

def ref_match(ref):
    """MATCH clause binding the reference point; returns (clause, x-expr, z-expr)."""
    t, v = ref
    if t == "start" or t == "end":
        order = "ASC" if t == "start" else "DESC"
        return (f"MATCH (f:Frame) WITH f ORDER BY f.index {order} LIMIT 1",
                "f.world_from_velo[3]", "f.world_from_velo[11]")
    if t == "segment":
        return (f"MATCH (p:Segment) WHERE id(p) = {v}", "p.centroid.x", "p.centroid.z")
    if t == "lane":
        return (f"MATCH (p:LaneNode) WHERE id(p) = {v}", "p.position.x", "p.position.z")
    if t == "object":
        return (f"MATCH (p:Instance) WHERE id(p) = {v}", "p.centroid.x", "p.centroid.z")
    raise ValueError(ref)

def q_distances(label, ref):
    m, x, z = ref_match(ref)
    return (f"{m} MATCH (n:Instance {{label: '{label}'}}) "
            f"RETURN id(n) AS id, sqrt((n.centroid.x - {x})^2 + (n.centroid.z - {z})^2) AS d ORDER BY d")

def q_pair(a, b):
    ma, xa, za = ref_match(a)
    mb, xb, zb = ref_match(b)
    mb = mb.replace("(p:", "(q:").replace("id(p)", "id(q)").replace("WITH f", "WITH g").replace("(f:", "(g:")
    xb = xb.replace("p.", "q.").replace("f.", "g."); zb = zb.replace("p.", "q.").replace("f.", "g.")
    return f"{ma} {mb} RETURN sqrt(({xa} - {xb})^2 + ({za} - {zb})^2) AS d"

Q_LANES = "MATCH (a:LaneNode)-[r:LANE]->(b:LaneNode) RETURN id(a) AS a, id(b) AS b, r.length_m AS len"

def q_count(label):
    return f"MATCH (n:Instance {{label: '{label}'}}) RETURN count(n) AS count"

def q_count_within(label, seg):
    return (f"MATCH (n:Instance {{label: '{label}'}})-[:IN_SEGMENT]->(s:Segment) "
            f"WHERE id(s) = {seg} RETURN count(n) AS count")

def q_count_segments(kinds):
    lst = ", ".join(f"'{k}'" for k in kinds)
    return f"MATCH (s:Segment) WHERE s.kind IN [{lst}] RETURN count(s) AS count"

def q_segment(obj):
    return (f"MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE id(n) = {obj} "
            f"RETURN id(s) AS id, s.kind AS kind")

def q_colour(obj):
    return f"MATCH (n:Instance) WHERE id(n) = {obj} RETURN n.colour AS colour, n.captions AS captions"

# ---------------------------------------------------------------- the spec
# desc: descriptions of single objects in the question: (object id, noun key, colour|None, attr regex|None, segment|None)
S = []
def add(voice, kind, question, truth, cypher, calc, desc=(), **kw):
    S.append(dict(voice=voice, kind=kind, question=question, truth=truth, cypher=cypher,
                  calc=calc, desc=list(desc), **kw))

# ===== Voice A: night-shift security guard radioing in
A = "A-security-guard"
add(A, "count", "Control, unit four on the night round. How many fire hydrants have we got on the whole map, over?",
    {"count": 9}, q_count("hydrant"), "count", label="hydrant")
add(A, "count", "Dispatch, quick one while I walk the block: how many traffic lights are there across the entire area we cover?",
    {"count": 18}, q_count("traffic light"), "count", label="traffic light")
add(A, "count_within", "I'm doing a bin check along segment 2421. How many rubbish bins should I find in that segment, over?",
    {"count": 4}, q_count_within("rubbish bin", 2421), "count", label="rubbish bin")
add(A, "count_within", "Control, heading into segment 2406 now. How many traffic lights does the map show inside that segment?",
    {"count": 4}, q_count_within("traffic light", 2406), "count", label="traffic light")
add(A, "count_segments", "Base, for the patrol log: how many crossroads are on the map, the proper four-way ones?",
    {"count": 3}, q_count_segments(["intersection"]), "count")
add(A, "count_segments", "Control, how many junctions am I covering tonight in total? Count every type, crossroads, T-junctions and the corner bends. Over.",
    {"count": 9}, q_count_segments(["intersection", "t_intersection", "l_intersection"]), "count")
add(A, "count_near", "I'm back at the spot where the survey drive started. How many traffic lights are within 30 metres of that starting point, over?",
    {"count": 4}, q_distances("traffic light", ("start", None)), "near_count", radius=30, label="traffic light")
add(A, "count_near", "Standing in the middle of segment 2412. How many post boxes are within 30 metres of me, over?",
    {"count": 2}, q_distances("letter box", ("segment", 2412)), "near_count", radius=30, label="letter box")
add(A, "nearest", "Control, I'm where the drive started. Which fire hydrant is closest to me? Give me its node id.",
    {"id": 665}, q_distances("hydrant", ("start", None)), "nearest", label="hydrant")
add(A, "nearest", "Unit four at segment 2403. Which traffic light is nearest to the centre of that segment, over?",
    {"id": 275}, q_distances("traffic light", ("segment", 2403)), "nearest", label="traffic light")
add(A, "distance", "Control, how far is it from that heavy scooter on its kickstand to the middle of segment 2401? Straight line, metres.",
    {"distance_m": 53.29}, q_pair(("object", 64), ("segment", 2401)), "distance",
    desc=[(64, "scooter", None, r"\bheavy\b", None)])
add(A, "distance", "Base, what's the straight-line distance between segment 2404 and segment 2406, in metres?",
    {"distance_m": 82.25}, q_pair(("segment", 2404), ("segment", 2406)), "distance")
add(A, "route_length", "Control, if I take the patrol car along the lanes from lane node 2424 to lane node 2430, what's the shortest route length in metres?",
    {"length_m": 183.75}, Q_LANES, "route", src=2424, dst=2430)
add(A, "route_length", "Dispatch, I need the shortest driving distance over the lane network between node 2431 and node 2433, over.",
    {"length_m": 308.22}, Q_LANES, "route", src=2431, dst=2433)
add(A, "segment", "Base, there's a blue camper van parked up that I want logged. Which segment is it in? Segment id please.",
    {"id": 2413}, q_segment(428), "segment", desc=[(428, "camper van", "blue", None, None)])
add(A, "segment", "Control, I've spotted a red SUV sitting there after hours. Which road segment is that in, over?",
    {"id": 2420}, q_segment(1826), "segment", desc=[(1826, "suv", "red", None, None)])
add(A, "segment_kind", "Control, the silver fire hydrant: what kind of road section is it on? Crossroads, T-junction, bend or straight road?",
    {"kind": "straight_road"}, q_segment(922), "segment_kind", desc=[(922, "hydrant", "silver", None, None)])
add(A, "segment_kind", "Unit four, I've got eyes on the small grey sedan. What sort of road segment is it parked in, over?",
    {"kind": "t_junction"}, q_segment(1300), "segment_kind", desc=[(1300, "sedan", "grey", r"\bsmall\b", None)])
add(A, "colour", "Control, there's a heavy scooter standing on its kickstand on my route. What colour has the map got it down as, over?",
    {"colour": "blue"}, q_colour(64), "colour", desc=[(64, "scooter", None, r"\bheavy\b", None)])
add(A, "colour", "Base, checking the post box on segment 2422. What colour should it be?",
    {"colour": "yellow"}, q_colour(2133), "colour", desc=[(2133, "post box", None, None, 2422)])

# ===== Voice B: road-maintenance contractor, terse work order
B = "B-maintenance-contractor"
add(B, "count", "WO-114, signage inventory. Total speed limit signs on the network? Count required.",
    {"count": 7}, q_count("speed limit sign"), "count", label="speed limit sign")
add(B, "count", "Work order: trailer audit before resurfacing. Number of trailers on the whole map.",
    {"count": 8}, q_count("trailer"), "count", label="trailer")
add(B, "count_within", "WO-207 hydrant flushing, segment 2414. No. of hydrants in segment?",
    {"count": 2}, q_count_within("hydrant", 2414), "count", label="hydrant")
add(B, "count_within", "Sign replacement job, seg 2413. Qty of speed limit signs within that segment?",
    {"count": 2}, q_count_within("speed limit sign", 2413), "count", label="speed limit sign")
add(B, "count_segments", "Resurfacing programme. Number of straight road segments on the map?",
    {"count": 14}, q_count_segments(["straight_roadway"]), "count")
add(B, "count_segments", "Kerb works at corners. How many bend segments (L-shaped, road turns, no side road)?",
    {"count": 4}, q_count_segments(["l_intersection"]), "count")
add(B, "count_near", "Bin collection zone: 40 m radius around lane node 2432. Bin count inside radius?",
    {"count": 3}, q_distances("rubbish bin", ("lane", 2432)), "near_count", radius=40, label="rubbish bin")
add(B, "count_near", "Excavation permit near the silver camper van. Hydrants within 50 m of it - how many?",
    {"count": 2}, q_distances("hydrant", ("object", 1089)), "near_count", radius=50, label="hydrant",
    desc=[(1089, "camper van", "silver", None, None)])
add(B, "nearest", "Skip placement, segment 2404. Nearest rubbish bin to segment centre - node id.",
    {"id": 390}, q_distances("rubbish bin", ("segment", 2404)), "nearest", label="rubbish bin")
add(B, "nearest", "Valve check at lane node 2429. Closest hydrant? Node id required.",
    {"id": 2071}, q_distances("hydrant", ("lane", 2429)), "nearest", label="hydrant")
add(B, "distance", "Cone layout: ground distance from the red delivery truck to the centre of segment 2415, metres.",
    {"distance_m": 7.93}, q_pair(("object", 998), ("segment", 2415)), "distance",
    desc=[(998, "delivery truck", "red", None, None)])
add(B, "distance", "Pipe run estimate. Straight-line distance hydrant 922 to hydrant 858, m.",
    {"distance_m": 38.16}, q_pair(("object", 922), ("object", 858)), "distance")
add(B, "route_length", "Crew transport: shortest lane route, node 2433 to node 2434. Length in metres.",
    {"length_m": 307.17}, Q_LANES, "route", src=2433, dst=2434)
add(B, "route_length", "Sweeper run, lane node 2425 to lane node 2432. Shortest path length along lanes, m?",
    {"length_m": 346.55}, Q_LANES, "route", src=2425, dst=2432)
add(B, "segment", "Tow notice for the silver camper van. Segment id?",
    {"id": 2422}, q_segment(1089), "segment", desc=[(1089, "camper van", "silver", None, None)])
add(B, "segment", "Parking suspension: beige camper van. Which segment is it in?",
    {"id": 2423}, q_segment(2286), "segment", desc=[(2286, "camper van", "beige", None, None)])
add(B, "segment_kind", "Heavy red motorbike obstructing works area. Segment type? (crossroads / T-junction / bend / straight)",
    {"kind": "bend"}, q_segment(1433), "segment_kind", desc=[(1433, "motorbike", "red", r"\bheavy\b", None)])
add(B, "segment_kind", "Blue speed limit sign due for refurb. What type of road segment is it on?",
    {"kind": "straight_road"}, q_segment(302), "segment_kind", desc=[(302, "speed limit sign", "blue", None, None)])
add(B, "colour", "Hydrant in segment 2418, recorded colour? Needed for paint order.",
    {"colour": "red"}, q_colour(1383), "colour", desc=[(1383, "hydrant", None, None, 2418)])
add(B, "colour", "Traffic light on segment 2412 - housing colour as per map?",
    {"colour": "black"}, q_colour(274), "colour", desc=[(274, "traffic light", None, None, 2412)])

# ===== Voice C: curious 12-year-old
C = "C-curious-kid"
add(C, "count", "I'm trying to count every mailbox in the whole city. How many are there?",
    {"count": 11}, q_count("letter box"), "count", label="letter box")
add(C, "count", "How many trash cans are there on the entire map? I bet it's more than ten!",
    {"count": 19}, q_count("rubbish bin"), "count", label="rubbish bin")
add(C, "count_within", "How many hatchbacks are parked in segment 2411?",
    {"count": 4}, q_count_within("hatchback", 2411), "count", label="hatchback")
add(C, "count_within", "My friend lives by segment 2416. How many post boxes are in that segment?",
    {"count": 3}, q_count_within("letter box", 2416), "count", label="letter box")
add(C, "count_segments", "How many T-junctions are there? You know, where one road runs into another one like the letter T.",
    {"count": 2}, q_count_segments(["t_intersection"]), "count")
add(C, "count_segments", "How many crossroads does the city have, like where two roads cross each other in a plus sign?",
    {"count": 3}, q_count_segments(["intersection"]), "count")
add(C, "count_near", "The car that made the map stopped somewhere at the end of its drive, right? How many hatchbacks are within 30 metres of where it stopped?",
    {"count": 3}, q_distances("hatchback", ("end", None)), "near_count", radius=30, label="hatchback")
add(C, "count_near", "I'm sitting on the green climbing frame. How many post boxes are within 25 metres of me?",
    {"count": 3}, q_distances("letter box", ("object", 1108)), "near_count", radius=25, label="letter box",
    desc=[(1108, "climbing frame", "green", None, None)])
add(C, "nearest", "Which mailbox is the closest one to where the drive finished? What's its id?",
    {"id": 16}, q_distances("letter box", ("end", None)), "nearest", label="letter box")
add(C, "nearest", "I just finished a snack at the green climbing frame. Which bin is nearest so I can throw the wrapper away?",
    {"id": 1169}, q_distances("rubbish bin", ("object", 1108)), "nearest", label="rubbish bin",
    desc=[(1108, "climbing frame", "green", None, None)])
add(C, "distance", "How far is the green climbing frame from the middle of segment 2409, in metres?",
    {"distance_m": 64.42}, q_pair(("object", 1108), ("segment", 2409)), "distance",
    desc=[(1108, "climbing frame", "green", None, None)])
add(C, "distance", "How far apart are the yellow SUV and the red SUV? Like in a straight line.",
    {"distance_m": 125.48}, q_pair(("object", 995), ("object", 1826)), "distance",
    desc=[(995, "suv", "yellow", None, None), (1826, "suv", "red", None, None)])
add(C, "route_length", "If you drive along the lanes from lane node 2426 to lane node 2429, how long is the shortest way?",
    {"length_m": 174.53}, Q_LANES, "route", src=2426, dst=2429)
add(C, "route_length", "What's the shortest way along the lanes from node 2428 to node 2432, in metres? I want to know how long it'd take on my bike.",
    {"length_m": 187.08}, Q_LANES, "route", src=2428, dst=2432)
add(C, "segment", "There's a red scooter I really like. Which segment is it in?",
    {"id": 2420}, q_segment(1828), "segment", desc=[(1828, "scooter", "red", None, None)])
add(C, "segment", "Which segment has the green sedan in it?",
    {"id": 2421}, q_segment(1314), "segment", desc=[(1314, "sedan", "green", None, None)])
add(C, "segment_kind", "Is the silver scooter on a straight road, a bend, a T-junction or a crossroads?",
    {"kind": "straight_road"}, q_segment(2059), "segment_kind", desc=[(2059, "scooter", "silver", None, None)])
add(C, "segment_kind", "What kind of road is the yellow SUV parked on?",
    {"kind": "straight_road"}, q_segment(995), "segment_kind", desc=[(995, "suv", "yellow", None, None)])
add(C, "colour", "What colour is the hatchback in segment 2420?",
    {"colour": "blue"}, q_colour(1860), "colour", desc=[(1860, "hatchback", None, None, 2420)])
add(C, "colour", "There's a minibus parked in the parking lane, not by the curb like the others. What colour is it?",
    {"colour": "beige"}, q_colour(1964), "colour", desc=[(1964, "minibus", None, r"parking lane", None)])

# ---------------------------------------------------------------- running
_cache = {}
def run(cypher):
    if cypher not in _cache:
        p = subprocess.run([OG, "query", "--db", DB, "--read-only", "--json", cypher],
                           capture_output=True, text=True, timeout=120)
        if p.returncode != 0:
            raise RuntimeError(f"query failed: {cypher}\n{p.stderr}")
        _cache[cypher] = json.loads(p.stdout)
    return _cache[cypher]

def dijkstra(rows, s, t):
    g = defaultdict(list)
    for r in rows:  # stored one way, meant undirected
        g[r["a"]].append((r["b"], r["len"])); g[r["b"]].append((r["a"], r["len"]))
    dist = {s: 0.0}; pq = [(0.0, s)]
    while pq:
        d, u = heapq.heappop(pq)
        if u == t:
            return d
        if d > dist[u]:
            continue
        for v, w in g[u]:
            if d + w < dist.get(v, math.inf):
                dist[v] = d + w; heapq.heappush(pq, (d + w, v))
    return None

def compute(q, problems):
    rows = run(q["cypher"]); c = q["calc"]
    if c == "count":
        return {"count": rows[0]["count"]}
    if c == "near_count":
        R = q["radius"]; ds = [r["d"] for r in rows]
        close = [d for d in ds if abs(d - R) < NEAR_MARGIN_M]
        if close:
            problems.append(f"radius margin: objects at {close} vs R={R}")
        return {"count": sum(d < R for d in ds)}
    if c == "nearest":
        rs = sorted(rows, key=lambda r: r["d"])
        if len(rs) > 1 and rs[1]["d"] - rs[0]["d"] < NEAREST_GAP_M:
            problems.append(f"nearest gap {rs[1]['d'] - rs[0]['d']:.2f} m < {NEAREST_GAP_M}")
        return {"id": rs[0]["id"]}
    if c == "distance":
        assert len(rows) == 1
        return {"distance_m": round(rows[0]["d"], 2)}
    if c == "route":
        d = dijkstra(rows, q["src"], q["dst"])
        return {"length_m": round(d, 2)}
    if c == "segment":
        if len(rows) != 1:
            problems.append(f"object in {len(rows)} segments")
        return {"id": rows[0]["id"]}
    if c == "segment_kind":
        if len(rows) != 1:
            problems.append(f"object in {len(rows)} segments")
        return {"kind": KIND_MAP[rows[0]["kind"]]}
    if c == "colour":
        col = rows[0]["colour"]; caps = rows[0]["captions"] or []
        if not col:
            problems.append("colour property is null")
        else:
            for cap in caps:
                named = {c2 for c2 in COLOURS if re.search(rf"\b{c2}\b", cap, re.I)}
                if named != {col}:
                    problems.append(f"caption disagrees with colour {col!r}: {cap!r}")
        return {"colour": col}
    raise ValueError(c)

# ---------------------------------------------------------------- audits
Q_ALL = ("MATCH (n:Instance) OPTIONAL MATCH (n)-[:IN_SEGMENT]->(s:Segment) "
         "RETURN id(n) AS id, n.label AS label, n.colour AS colour, n.captions AS captions, collect(id(s)) AS segs")

def names(o, rx):
    r = re.compile(rx, re.I)
    return bool(r.search(o["label"] or "")) or any(r.search(c) for c in (o["captions"] or []))

def names_colour(o, col):
    return o["colour"] == col or any(re.search(rf"\b{col}\b", c, re.I) for c in (o["captions"] or []))

def desc_matches(objs, noun, colour, attr, segment):
    out = []
    for o in objs:
        if not names(o, NOUNS[noun]):
            continue
        if colour and not names_colour(o, colour):
            continue
        if attr and not any(re.search(attr, c, re.I) for c in (o["captions"] or [])):
            continue
        if segment is not None and segment not in o["segs"]:
            continue
        out.append(o["id"])
    return out

def label_audit(objs, label, problems):
    rx = re.compile(KINDS[label], re.I)
    mine = [o for o in objs if o["label"] == label]
    for o in mine:
        if not any(rx.search(c) for c in (o["captions"] or [])):
            problems.append(f"{label}: object {o['id']} has no caption naming the kind")
    for o in objs:
        if o["label"] == label:
            continue
        hits = [c for c in (o["captions"] or []) + [o["label"] or ""] if rx.search(c)]
        if hits:
            problems.append(f"{label}: object {o['id']} labelled {o['label']!r} is captioned as the kind: {hits[0]!r}")
    return len(mine)

def main():
    write = "--write" in sys.argv
    objs = run(Q_ALL)
    fails = []
    # global: one segment per object (count_within / segment questions rely on it)
    multi = [o["id"] for o in objs if len(o["segs"]) != 1]
    if multi:
        fails.append(f"objects not in exactly one segment: {multi[:10]}")
    label_totals = {}
    for lab in KINDS:
        probs = []
        label_totals[lab] = label_audit(objs, lab, probs)
        fails += probs
    # per question
    kinds = Counter(); voices = Counter(); vk = Counter()
    for i, q in enumerate(S, 1):
        probs = []
        got = compute(q, probs)
        if got != q["truth"]:
            probs.append(f"truth mismatch: spec {q['truth']} vs recomputed {got}")
        for (oid, noun, colour, attr, segment) in q["desc"]:
            m = desc_matches(objs, noun, colour, attr, segment)
            if m != [oid]:
                probs.append(f"description ({noun}, {colour}, {attr}, seg {segment}) matches {m}, expected [{oid}]")
        if q.get("label") and q["label"] not in KINDS:
            probs.append(f"label {q['label']} not audited")
        for p in probs:
            fails.append(f"Q{i:02d} [{q['kind']}] {p}")
        kinds[q["kind"]] += 1; voices[q["voice"]] += 1; vk[(q["voice"], q["kind"])] += 1
    if len(S) != 60 or any(v != 6 for v in kinds.values()) or len(kinds) != 10:
        fails.append(f"kind distribution wrong: {dict(kinds)}")
    if any(v != 20 for v in voices.values()) or len(voices) != 3 or any(v != 2 for v in vk.values()):
        fails.append(f"voice distribution wrong: {dict(voices)}")
    if len({q['question'] for q in S}) != len(S):
        fails.append("duplicate question text")
    records = [{"kind": q["kind"], "question": q["question"], "truth": q["truth"], "cypher": q["cypher"]} for q in S]
    if write and not fails:
        with open(OUT, "w") as f:
            for r in records:
                f.write(json.dumps(r, ensure_ascii=False) + "\n")
    # compare with the file on disk
    if os.path.exists(OUT):
        disk = [json.loads(l) for l in open(OUT) if l.strip()]
        if disk != records:
            fails.append("questions.jsonl differs from the spec (run with --write)")
    else:
        fails.append("questions.jsonl missing (run with --write)")
    print("label totals:", json.dumps(label_totals))
    for f in fails:
        print("FAIL:", f)
    if fails:
        print(f"RESULT: FAIL ({len(fails)} problem(s)) over {len(S)} questions")
        sys.exit(1)
    print(f"RESULT: PASS - {len(S)} questions, truths recomputed from {len(_cache) - 1} distinct cypher statements, "
          f"all audits (labels, descriptions, radius margins >= {NEAR_MARGIN_M} m, nearest gaps >= {NEAREST_GAP_M} m, colours) ok")

if __name__ == "__main__":
    main()
