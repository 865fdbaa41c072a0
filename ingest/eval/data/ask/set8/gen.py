#!/usr/bin/env python3
"""Held-out question set 8: spec, truth recomputation and audits.

Usage:
  python3 gen.py           # re-run every cypher, recompute truths, run audits, compare with questions.jsonl
  python3 gen.py --write   # same, then (re)write questions.jsonl from the spec (only if everything passes)

Environment:
  OPENGRAPH          the opengraph CLI (default /tmp/ask8/opengraph)
  OPENGRAPH_ASK_DB   the map store   (default /tmp/ask8/city.og; the default small city,
                     `opengraph sim --size small --seed 0` + `opengraph build`, commit e5afdf6)

Every query is run with --read-only. Ground plane is (x, z); y is up.
"""
import heapq
import json
import math
import os
import re
import subprocess
import sys
from collections import Counter, defaultdict

OG = os.environ.get("OPENGRAPH", "/tmp/ask8/opengraph")
DB = os.environ.get("OPENGRAPH_ASK_DB", "/tmp/ask8/city.og")
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "questions.jsonl")

KIND_MAP = {"intersection": "crossroads", "t_intersection": "t_junction",
            "l_intersection": "bend", "straight_roadway": "straight_road"}
NEAR_MARGIN_M = 1.0      # count_near: no object of the kind within this of the radius
NEAREST_GAP_M = 0.5      # nearest: second nearest at least this much farther
ROUTE_GAP_M = 10.0       # route_length: second-best simple path at least this much longer

# ---------------------------------------------------------------- vocabulary
# Labels that are counted / searched for, with a broad regex for how a caption (or label)
# names the kind (synonyms included). The audit requires every object of the label to have a
# caption matching it, and no object of any other label (or unlabelled) to match it.
KINDS = {
    "hydrant":          r"hydrant",
    "letter box":       r"post ?box|letter ?box|mail ?box|pillar box",
    "rubbish bin":      r"\bbins?\b|trash|rubbish|litter|garbage|dustbin|waste",
    "traffic light":    r"traffic (light|signal)|stop ?light|\bsignals?\b",
    "trailer":          r"trailer",
    "hatchback":        r"hatchback",
    "suv":              r"\bsuvs?\b|sport utility|4x4",
    "sedan":            r"sedan|saloon",
    "scooter":          r"scooter|moped",
}
# Nouns used in descriptions of single objects (broad readings: label or any caption).
NOUNS = {
    "trailer":          r"trailer",
    "hydrant":          r"hydrant",
    "bin":              r"\bbins?\b|trash|rubbish|litter|garbage|dustbin|waste",
    "traffic light":    r"traffic (light|signal)|\bsignals?\b|stop ?light",
    "hedge":            r"hedge|bush",
    "bus shelter":      r"shelter|bus stop",
    "hatchback":        r"hatchback",
    "suv":              r"\bsuv\b",
    "sedan":            r"sedan|saloon",
    "motorbike":        r"motorbike|motorcycle",
    "bike":             r"\bbikes?\b|bicycle|cycle",
    "delivery truck":   r"truck|lorry|\bvan\b",
    "billboard":        r"billboard|poster|advertising",
}
COLOURS = ["red", "blue", "green", "yellow", "white", "black", "grey", "gray", "silver",
           "beige", "orange", "brown", "pink", "purple"]

# ---------------------------------------------------------------- cypher builders
def ref_match(ref):
    """MATCH clause binding the reference point; returns (clause, x-expr, z-expr)."""
    t, v = ref
    if t in ("start", "end"):
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
Q_ALL_SEGMENTS = "MATCH (s:Segment) RETURN count(s) AS count"

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
# desc: descriptions of single objects used in the question:
#   (object id, noun key, colour|None, [attribute regexes] (each must match some caption), segment|None)
S = []
def add(voice, kind, question, truth, cypher, calc, desc=(), **kw):
    S.append(dict(voice=voice, kind=kind, question=question, truth=truth, cypher=cypher,
                  calc=calc, desc=list(desc), **kw))

# Description shorthands (each audited to match exactly one Instance under the broad reading).
BOX_TRUCK = (2056, "delivery truck", "white", [r"\bheavy\b", r"unloading"], None)      # heavy white box truck unloading
YELLOW_HB = (1734, "hatchback", "yellow", [r"parking lane"], None)                      # yellow hatchback in the parking lane
SILVER_HYD = (892, "hydrant", "silver", None, None)                                      # silver fire hydrant
POSTER = (2016, "billboard", "white", [r"\bhuge\b", r"two posts"], None)                 # huge white poster board on two posts
SHELTER = (1053, "bus shelter", "green", [r"timetable"], None)                          # green bus shelter with a timetable
GREEN_SALOON = (1274, "sedan", "green", None, None)                                      # green saloon (sedan)

# ===== Voice D: insurance claims adjuster reconstructing an incident
D = "D-claims-adjuster"
add(D, "count", "I'm reconstructing a parking incident that involved an unhitched trailer, and for context in the report I need the total number of trailers recorded anywhere on the map.",
    {"count": 8}, q_count("trailer"), "count", label="trailer")
add(D, "count", "For the claim file I have to note how many saloon cars (sedans, in the policy wording) appear on the map as a whole. What's the total?",
    {"count": 6}, q_count("sedan"), "count", label="sedan")
add(D, "count_within", "The claimant says a wheelie bin rolled into her car somewhere in segment 2349. Before I take that further: how many rubbish bins are actually recorded in that segment?",
    {"count": 4}, q_count_within("rubbish bin", 2349), "count", label="rubbish bin")
add(D, "count_within", "Our policyholder's car was reportedly sideswiped while parked in segment 2339, and I want a sense of how crowded it was. Could you count the hatchbacks recorded in segment 2339?",
    {"count": 4}, q_count_within("hatchback", 2339), "count", label="hatchback")
add(D, "count_segments", "A lot of the collisions I handle happen where four roads meet. How many crossroads are there on this map?",
    {"count": 3}, q_count_segments(["intersection"]), "count")
add(D, "count_segments", "For a junction-risk summary I need the number of junctions that are not full crossroads, meaning the T-junctions and the bends taken together.",
    {"count": 6}, q_count_segments(["t_intersection", "l_intersection"]), "count")
add(D, "count_near", "The witness puts the incident right where the survey vehicle's recording ends. How many fire hydrants are there within 40 metres of the point where the survey vehicle finished recording?",
    {"count": 3}, q_distances("hydrant", ("end", None)), "near_count", radius=40, label="hydrant")
add(D, "count_near", "Let's take the centre of segment 2347 as the spot where the cyclist came off. How many rubbish bins lie within 50 metres of that point?",
    {"count": 3}, q_distances("rubbish bin", ("segment", 2347)), "near_count", radius=50, label="rubbish bin")
add(D, "nearest", "The heavy white box truck that was unloading at the roadside is central to this claim. Which traffic light stands closest to it? Give me the node id so I can request that signal's log.",
    {"id": 1064}, q_distances("traffic light", ("object", 2056)), "nearest", label="traffic light", desc=[BOX_TRUCK])
add(D, "nearest", "The driver states he pulled away from lane node 2359 moments before the impact. Which fire hydrant is nearest to that lane node? I need its id for the damage report.",
    {"id": 1439}, q_distances("hydrant", ("lane", 2359)), "nearest", label="hydrant")
add(D, "distance", "In his statement the other driver describes the heavy white box truck unloading at the roadside and the yellow hatchback in the parking lane as 'practically touching'. What is the straight-line distance between the two, in metres?",
    {"distance_m": 16.96}, q_pair(("object", 2056), ("object", 1734)), "distance", desc=[BOX_TRUCK, YELLOW_HB])
add(D, "distance", "I'm checking the timeline against the dashcam footage. In a straight line, how far is the point where the survey vehicle finished recording from the centre of segment 2342?",
    {"distance_m": 42.29}, q_pair(("end", None), ("segment", 2342)), "distance")
add(D, "route_length", "The tow operator claims he drove from lane node 2353 to lane node 2358 by the shortest way. Following the lanes, how long is that shortest route in metres? I want to see whether the mileage he billed is plausible.",
    {"length_m": 265.45}, Q_LANES, "route", src=2353, dst=2358)
add(D, "route_length", "To verify a courier's account of the journey, I need the length of the shortest route along the lane network from lane node 2356 to lane node 2362.",
    {"length_m": 163.18}, Q_LANES, "route", src=2356, dst=2362)
add(D, "segment", "Damage has been reported to the red SUV. Which segment is it parked in? I only need the segment id for the location field on the form.",
    {"id": 2348}, q_segment(1764), "segment", desc=[(1764, "suv", "red", None, None)])
add(D, "segment", "Third-party vehicle: a grey saloon with dusty windows. Which segment of the map is it recorded in?",
    {"id": 2351}, q_segment(2215), "segment", desc=[(2215, "sedan", "grey", [r"dusty"], None)])
add(D, "segment_kind", "The long cargo trailer parked by the curb was struck by a reversing van. Was the trailer standing on a straight road, at a bend, at a T-junction or at a crossroads?",
    {"kind": "bend"}, q_segment(86), "segment_kind", desc=[(86, "trailer", None, [r"\blong\b", r"cargo", r"by the curb"], None)])
add(D, "segment_kind", "The round green plastic bin got knocked over during the incident. What kind of road segment was it on: straight road, bend, T-junction or crossroads?",
    {"kind": "t_junction"}, q_segment(1263), "segment_kind", desc=[(1263, "bin", "green", [r"\bround\b", r"plastic"], None)])
add(D, "colour", "A witness mentions a large SUV with dusty windows near the scene but can't remember much else. What colour is that SUV on record?",
    {"colour": "grey"}, q_colour(12), "colour", desc=[(12, "suv", None, [r"\blarge\b", r"dusty"], None)])
add(D, "colour", "For the photo log, what colour is the small box trailer that's parked by the curb?",
    {"colour": "silver"}, q_colour(692), "colour", desc=[(692, "trailer", None, [r"\bsmall\b", r"box trailer", r"by the curb"], None)])

# ===== Voice E: delivery-drone operator, terse checklist-style queries
E = "E-drone-operator"
add(E, "count", "Pre-flight check, item 1: total fire hydrants on the map. Number only.",
    {"count": 9}, q_count("hydrant"), "count", label="hydrant")
add(E, "count", "Obstacle inventory. SUVs, whole map, count?",
    {"count": 12}, q_count("suv"), "count", label="suv")
add(E, "count_within", "Drop zone = segment 2344. Letter boxes in that segment: how many?",
    {"count": 3}, q_count_within("letter box", 2344), "count", label="letter box")
add(E, "count_within", "Landing corridor check - SUVs inside segment 2348, count.",
    {"count": 3}, q_count_within("suv", 2348), "count", label="suv")
add(E, "count_segments", "Route planning: number of straight road segments on the map?",
    {"count": 14}, q_count_segments(["straight_roadway"]), "count")
add(E, "count_segments", "Turn-margin table: number of bends on the map (L-shaped corners, not T's or crossroads)?",
    {"count": 4}, q_count_segments(["l_intersection"]), "count")
add(E, "count_near", "Hover point: lane node 2353. Trailers within 25 m of it? Count.",
    {"count": 2}, q_distances("trailer", ("lane", 2353)), "near_count", radius=25, label="trailer")
add(E, "count_near", "Waypoint lane node 2361, radius 60 m. How many letter boxes inside that radius?",
    {"count": 2}, q_distances("letter box", ("lane", 2361)), "near_count", radius=60, label="letter box")
add(E, "nearest", "Hovering over the centre of segment 2339. Nearest letter box: id?",
    {"id": 203}, q_distances("letter box", ("segment", 2339)), "nearest", label="letter box")
add(E, "nearest", "Visual landmark: the huge white poster board on two posts. Closest SUV to it, id only.",
    {"id": 1737}, q_distances("suv", ("object", 2016)), "nearest", label="suv", desc=[POSTER])
add(E, "distance", "Leg check: lane node 2356 to lane node 2360, straight line, metres.",
    {"distance_m": 173.45}, q_pair(("lane", 2356), ("lane", 2360)), "distance")
add(E, "distance", "Straight-line distance from the centre of segment 2347 to the silver fire hydrant, in metres?",
    {"distance_m": 210.13}, q_pair(("segment", 2347), ("object", 892)), "distance", desc=[SILVER_HYD])
add(E, "route_length", "Ground fallback plan: shortest route along the lanes, lane node 2354 to lane node 2361. Length in m.",
    {"length_m": 226.66}, Q_LANES, "route", src=2354, dst=2361)
add(E, "route_length", "Backup path, lane node 2360 -> lane node 2362, shortest along the lanes, metres?",
    {"length_m": 336.4}, Q_LANES, "route", src=2360, dst=2362)
add(E, "segment", "Silver fire hydrant: which segment is it in? Segment id.",
    {"id": 2342}, q_segment(892), "segment", desc=[SILVER_HYD])
add(E, "segment", "Pickup at the green bus shelter with the timetable. Segment id?",
    {"id": 2344}, q_segment(1053), "segment", desc=[SHELTER])
add(E, "segment_kind", "Tall grey traffic signal showing green: segment type? (straight road / bend / T-junction / crossroads)",
    {"kind": "crossroads"}, q_segment(1062), "segment_kind",
    desc=[(1062, "traffic light", "grey", [r"\btall\b", r"showing green"], None)])
add(E, "segment_kind", "White SUV parked in the parking lane - straight road, bend, T or crossroads?",
    {"kind": "straight_road"}, q_segment(1360), "segment_kind", desc=[(1360, "suv", "white", [r"parking lane"], None)])
add(E, "colour", "Visual ID item: squat metal hydrant by the curb. Colour?",
    {"colour": "yellow"}, q_colour(996), "colour", desc=[(996, "hydrant", None, [r"\bsquat\b", r"\bmetal\b", r"by the curb"], None)])
add(E, "colour", "Heavy box truck unloading at the roadside. Colour, for visual confirmation from the air?",
    {"colour": "white"}, q_colour(2056), "colour", desc=[(2056, "delivery truck", None, [r"\bheavy\b", r"unloading"], None)])

# ===== Voice F: journalist fact-checking a story, hedged and indirect
F = "F-journalist-factcheck"
add(F, "count", "I'm checking a line in a draft that describes the area as 'full of hatchbacks'. Do you happen to know how many hatchbacks the map actually records, all told?",
    {"count": 20}, q_count("hatchback"), "count", label="hatchback")
add(F, "count", "A reader has written in to say there are hardly any scooters on these streets. I'd like to verify that before we print a correction: how many scooters are there on the whole map?",
    {"count": 3}, q_count("scooter"), "count", label="scooter")
add(F, "count_within", "Our reporter's notes say fire hydrants are 'clustered' in segment 2343. I'm not sure that holds up. How many hydrants does the map show in that segment?",
    {"count": 2}, q_count_within("hydrant", 2343), "count", label="hydrant")
add(F, "count_within", "One source insists that a trailer has been abandoned in segment 2350. Could you check how many trailers, if any, the map records in segment 2350?",
    {"count": 0}, q_count_within("trailer", 2350), "count", label="trailer", segment_must_exist=2350)
add(F, "count_segments", "For context in the piece it would help to know how many road segments the map is divided into altogether, whatever their type.",
    {"count": 23}, Q_ALL_SEGMENTS, "count")
add(F, "count_segments", "The article mentions 'a couple of T-junctions' in the area. Is that right? How many T-junctions does the map contain?",
    {"count": 2}, q_count_segments(["t_intersection"]), "count")
add(F, "count_near", "We describe the middle of segment 2351 as 'ringed by parked hatchbacks'. If it's not too much trouble, how many hatchbacks are within 30 metres of that segment's centre?",
    {"count": 3}, q_distances("hatchback", ("segment", 2351)), "near_count", radius=30, label="hatchback")
add(F, "count_near", "Apparently the green saloon is parked 'within sight of several traffic lights'. Would you be able to tell me how many traffic lights are within 40 metres of it?",
    {"count": 3}, q_distances("traffic light", ("object", 1274)), "near_count", radius=40, label="traffic light", desc=[GREEN_SALOON])
add(F, "nearest", "I'd like to confirm which trailer is closest to lane node 2362; the draft names one, but I suspect it's the wrong one. Could you give me that trailer's id?",
    {"id": 656}, q_distances("trailer", ("lane", 2362)), "nearest", label="trailer")
add(F, "nearest", "Someone told us the silver fire hydrant sits right next to a hatchback. Which hatchback is nearest to that hydrant, by id, if you can say?",
    {"id": 900}, q_distances("hatchback", ("object", 892)), "nearest", label="hatchback", desc=[SILVER_HYD])
add(F, "distance", "A photo caption claims the green bus shelter with the timetable is 'a stone's throw' from the huge white poster board on two posts. How far apart are they, in a straight line, in metres?",
    {"distance_m": 64.62}, q_pair(("object", 1053), ("object", 2016)), "distance", desc=[SHELTER, POSTER])
add(F, "distance", "I'm told the survey began 'just down the road' from lane node 2358. As the crow flies, how far is the point where the survey vehicle started recording from that lane node?",
    {"distance_m": 172.8}, q_pair(("start", None), ("lane", 2358)), "distance")
add(F, "route_length", "A delivery firm quoted us a figure for the drive from lane node 2352 to lane node 2358. What would the shortest route along the lanes between those two nodes come to, in metres, so I can compare?",
    {"length_m": 183.75}, Q_LANES, "route", src=2352, dst=2358)
add(F, "route_length", "Could you confirm the length of the shortest lane route between lane node 2356 and lane node 2360? The piece gives a number and I'd rather not take it on trust.",
    {"length_m": 187.08}, Q_LANES, "route", src=2356, dst=2360)
add(F, "segment", "We ran a photo of a huge white poster board on two posts, and I believe it's on the map too. Which segment is that board in, as far as you can tell?",
    {"id": 2350}, q_segment(2016), "segment", desc=[POSTER])
add(F, "segment", "There's a small black bicycle in one of our street photos. Would you know which segment the map has it in?",
    {"id": 2343}, q_segment(2128), "segment", desc=[(2128, "bike", "black", [r"\bsmall\b"], None)])
add(F, "segment_kind", "The piece says the trimmed hedge along a garden is on a straight stretch of road. I'm not convinced. What kind of segment is it really on: a straight road, a bend, a T-junction or a crossroads?",
    {"kind": "crossroads"}, q_segment(495), "segment_kind", desc=[(495, "hedge", None, [r"trimmed", r"along a garden"], None)])
add(F, "segment_kind", "Do you know what sort of road the tall yellow traffic signal showing green stands on? Would that be a straight road, a bend, a T-junction or a crossroads?",
    {"kind": "t_junction"}, q_segment(1276), "segment_kind",
    desc=[(1276, "traffic light", "yellow", [r"\btall\b", r"showing green"], None)])
add(F, "colour", "Our illustrator wants to get the small bin that's full of rubbish right. What colour does the map record it as?",
    {"colour": "orange"}, q_colour(1915), "colour", desc=[(1915, "bin", None, [r"\bsmall\b", r"full of rubbish"], None)])
add(F, "colour", "I'm not certain about the colour of the motorbike in segment 2349. Could you confirm what colour it's recorded as?",
    {"colour": "blue"}, q_colour(1776), "colour", desc=[(1776, "motorbike", None, None, 2349)])

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

def graph(rows):
    g = defaultdict(list)
    for r in rows:  # stored one way, treated as undirected
        g[r["a"]].append((r["b"], r["len"])); g[r["b"]].append((r["a"], r["len"]))
    return g

def dijkstra(g, s, t):
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

def simple_path_lengths(g, s, t):
    out = []
    def rec(u, seen, L):
        if u == t:
            out.append(L); return
        for v, w in g[u]:
            if v not in seen:
                rec(v, seen | {v}, L + w)
    rec(s, {s}, 0.0)
    return sorted(out)

def compute(q, problems):
    rows = run(q["cypher"]); c = q["calc"]
    if c == "count":
        return {"count": rows[0]["count"]}
    if c in ("near_count", "nearest") and any(r["d"] < 1e-9 for r in rows):
        problems.append("an object of the kind sits at the reference point itself")
    if c == "near_count":
        R = q["radius"]; ds = [r["d"] for r in rows]
        close = [round(d, 2) for d in ds if abs(d - R) < NEAR_MARGIN_M]
        if close:
            problems.append(f"radius margin: objects at {close} vs R={R}")
        return {"count": sum(d < R for d in ds)}
    if c == "nearest":
        rs = sorted(rows, key=lambda r: r["d"])
        if len(rs) > 1 and rs[1]["d"] - rs[0]["d"] < NEAREST_GAP_M:
            problems.append(f"nearest gap {rs[1]['d'] - rs[0]['d']:.2f} m < {NEAREST_GAP_M}")
        return {"id": rs[0]["id"]}
    if c == "distance":
        if len(rows) != 1:
            problems.append(f"distance query returned {len(rows)} rows")
            return None
        return {"distance_m": round(rows[0]["d"], 2)}
    if c == "route":
        g = graph(rows)
        d = dijkstra(g, q["src"], q["dst"])
        if d is None:
            problems.append("no route")
            return None
        ls = simple_path_lengths(g, q["src"], q["dst"])
        if len(ls) > 1 and ls[1] - ls[0] < ROUTE_GAP_M:
            problems.append(f"second-best path only {ls[1] - ls[0]:.2f} m longer")
        if abs(ls[0] - d) > 1e-6:
            problems.append("dijkstra disagrees with path enumeration")
        return {"length_m": round(d, 2)}
    if c in ("segment", "segment_kind"):
        if len(rows) != 1:
            problems.append(f"object in {len(rows)} segments")
            return None
        if c == "segment":
            return {"id": rows[0]["id"]}
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
Q_SEGS = "MATCH (s:Segment) RETURN id(s) AS id, s.kind AS kind"

def names(o, rx):
    r = re.compile(rx, re.I)
    return bool(r.search(o["label"] or "")) or any(r.search(c) for c in (o["captions"] or []))

def names_colour(o, col):
    return o["colour"] == col or any(re.search(rf"\b{col}\b", c, re.I) for c in (o["captions"] or []))

def desc_matches(objs, noun, colour, attrs, segment):
    out = []
    for o in objs:
        if not names(o, NOUNS[noun]):
            continue
        if colour and not names_colour(o, colour):
            continue
        if attrs and not all(any(re.search(a, c, re.I) for c in (o["captions"] or [])) for a in attrs):
            continue
        if segment is not None and segment not in o["segs"]:
            continue
        out.append(o["id"])
    return out

def label_audit(objs, label, problems):
    rx = re.compile(KINDS[label], re.I)
    mine = [o for o in objs if o["label"] == label]
    if not mine:
        problems.append(f"{label}: no objects with this label")
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
    segs = run(Q_SEGS)
    seg_ids = {r["id"] for r in segs}
    fails = []
    odd = sorted({r["kind"] for r in segs} - set(KIND_MAP))
    if odd:
        fails.append(f"segment kinds outside the four used in questions: {odd}")
    multi = [o["id"] for o in objs if len(o["segs"]) != 1]
    if multi:
        fails.append(f"objects not in exactly one segment: {multi[:10]}")
    label_totals = {}
    for lab in KINDS:
        probs = []
        label_totals[lab] = label_audit(objs, lab, probs)
        fails += probs
    kinds = Counter(); voices = Counter(); vk = Counter()
    for i, q in enumerate(S, 1):
        probs = []
        got = compute(q, probs)
        if got != q["truth"]:
            probs.append(f"truth mismatch: spec {q['truth']} vs recomputed {got}")
        for (oid, noun, colour, attrs, segment) in q["desc"]:
            m = desc_matches(objs, noun, colour, attrs, segment)
            if m != [oid]:
                probs.append(f"description ({noun}, {colour}, {attrs}, seg {segment}) matches {m}, expected [{oid}]")
        if q.get("label") and q["label"] not in KINDS:
            probs.append(f"label {q['label']} not audited")
        # a count over a segment id that does not exist would silently give 0
        for m in re.finditer(r"id\(s\) = (\d+)", q["cypher"]):
            if int(m.group(1)) not in seg_ids:
                probs.append(f"segment {m.group(1)} does not exist")
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
    if os.path.exists(OUT):
        disk = [json.loads(l) for l in open(OUT) if l.strip()]
        if disk != records:
            fails.append("questions.jsonl differs from the spec (run with --write)")
    else:
        fails.append("questions.jsonl missing (run with --write)")
    print("label totals:", json.dumps(label_totals))
    print("per kind:", json.dumps(dict(sorted(kinds.items()))), "per voice:", json.dumps(dict(sorted(voices.items()))))
    for f in fails:
        print("FAIL:", f)
    if fails:
        print(f"RESULT: FAIL ({len(fails)} problem(s)) over {len(S)} questions")
        sys.exit(1)
    print(f"RESULT: PASS - {len(S)} questions, truths recomputed from {len(_cache) - 2} distinct cypher statements, "
          f"all audits (labels, descriptions, radius margins >= {NEAR_MARGIN_M} m, nearest gaps >= {NEAREST_GAP_M} m, "
          f"route gaps >= {ROUTE_GAP_M} m, colours, segment ids) ok")

if __name__ == "__main__":
    main()
