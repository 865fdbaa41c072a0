#!/usr/bin/env python3
"""Held-out question set 7: spec, truth recomputation and audits.

Usage:
  python3 gen.py           # re-run every cypher, recompute truths, run audits, compare with questions.jsonl
  python3 gen.py --write   # same, then (re)write questions.jsonl from the spec (only if everything passes)

Environment:
  OPENGRAPH          the opengraph CLI (default /tmp/ask7/opengraph)
  OPENGRAPH_ASK_DB   the map store   (default /tmp/ask7/city.og; the default small city,
                     `opengraph sim --size small --seed 0` + `opengraph build`, commit 3b197be)

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

OG = os.environ.get("OPENGRAPH", "/tmp/ask7/opengraph")
DB = os.environ.get("OPENGRAPH_ASK_DB", "/tmp/ask7/city.og")
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
    "speed limit sign": r"speed limit|speed sign",
    "trailer":          r"trailer",
    "hatchback":        r"hatchback",
    "camper van":       r"camper|motorhome|\bvan\b|\brv\b",
}
# Nouns used in descriptions of single objects (broad readings: label or any caption).
NOUNS = {
    "scooter":          r"scooter|moped",
    "post box":         r"post ?box|letter ?box|mail ?box",
    "hydrant":          r"hydrant",
    "hatchback":        r"hatchback",
    "minibus":          r"minibus|\bbus\b",
    "camper van":       r"camper|motorhome|\bvan\b",
    "suv":              r"\bsuv\b",
    "sedan":            r"sedan|saloon",
    "motorbike":        r"motorbike|motorcycle",
    "bike":             r"\bbike|bicycle|cycle",
    "speed limit sign": r"speed limit",
    "delivery truck":   r"truck|lorry|\bvan\b",
    "climbing frame":   r"climbing frame|playground|play area",
    "bin":              r"\bbins?\b|trash|rubbish|litter|garbage|dustbin|waste",
    "trailer":          r"trailer",
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

# ===== Voice A: parcel courier dictating into a phone while driving
A = "A-courier-dictating"
add(A, "count", "ok quick one, I'm driving, how many letter boxes on the whole map, all of them",
    {"count": 11}, q_count("letter box"), "count", label="letter box")
add(A, "count", "Camper vans. Total on the map? Need to know how many I'm squeezing past today",
    {"count": 3}, q_count("camper van"), "count", label="camper van")
add(A, "count_within", "segment 2338 coming up, how many post boxes in that one",
    {"count": 2}, q_count_within("letter box", 2338), "count", label="letter box")
add(A, "count_within", "Looking for a gap to pull in on segment 2351 - hatchbacks parked there, how many?",
    {"count": 3}, q_count_within("hatchback", 2351), "count", label="hatchback")
add(A, "count_segments", "bends on this map, the corners where the road just turns, no side street, how many",
    {"count": 4}, q_count_segments(["l_intersection"]), "count")
add(A, "count_segments", "Junctions total, every sort, crossroads, T's, corners, the lot. Number?",
    {"count": 9}, q_count_segments(["intersection", "t_intersection", "l_intersection"]), "count")
add(A, "count_near", "parked up at the middle of segment 2346, litter bins within 25 metres of me, how many",
    {"count": 2}, q_distances("rubbish bin", ("segment", 2346)), "near_count", radius=25, label="rubbish bin")
add(A, "count_near", "Pulling in at lane node 2357. Mailboxes inside 25 m of there - count?",
    {"count": 4}, q_distances("letter box", ("lane", 2357)), "near_count", radius=25, label="letter box")
add(A, "nearest", "stuck behind the red delivery truck, what's the closest post box to it, node id",
    {"id": 1016}, q_distances("letter box", ("object", 966)), "nearest", label="letter box",
    desc=[(966, "delivery truck", "red", None, None)])
add(A, "nearest", "Centre of segment 2343, which trailer's nearest to that? Just the id",
    {"id": 990}, q_distances("trailer", ("segment", 2343)), "nearest", label="trailer")
add(A, "distance", "how far is the red delivery truck from that boxy minibus, straight line, metres",
    {"distance_m": 170.36}, q_pair(("object", 966), ("object", 167)), "distance",
    desc=[(966, "delivery truck", "red", None, None), (167, "minibus", None, [r"\bboxy\b"], None)])
add(A, "distance", "Segment 2338 centre to segment 2351 centre, as the crow flies, metres?",
    {"distance_m": 56.44}, q_pair(("segment", 2338), ("segment", 2351)), "distance")
add(A, "route_length", "shortest drive on the lanes lane node 2352 to lane node 2361, how many metres",
    {"length_m": 235.63}, Q_LANES, "route", src=2352, dst=2361)
add(A, "route_length", "Route length, lane node 2358 to lane node 2362, shortest way along the lanes, go",
    {"length_m": 255.29}, Q_LANES, "route", src=2358, dst=2362)
add(A, "segment", "drop-off's next to the compact red hatchback, which segment's that in",
    {"id": 2339}, q_segment(237), "segment", desc=[(237, "hatchback", "red", [r"compact"], None)])
add(A, "segment", "The big blue hatchback, the large one. Segment id?",
    {"id": 2348}, q_segment(1796), "segment", desc=[(1796, "hatchback", "blue", [r"\blarge\b"], None)])
add(A, "segment_kind", "that grey saloon in the parking lane, what sort of road is it on, straight, bend, T-junction or crossroads",
    {"kind": "t_junction"}, q_segment(1269), "segment_kind",
    desc=[(1269, "sedan", "grey", [r"parking lane"], None)])
add(A, "segment_kind", "Silver SUV, the one with the dusty windows - straight road, bend, T or crossroads?",
    {"kind": "straight_road"}, q_segment(1737), "segment_kind",
    desc=[(1737, "suv", "silver", [r"dusty"], None)])
add(A, "colour", "camper van sitting in the parking lane, what colour is it, so I can spot it",
    {"colour": "beige"}, q_colour(2213), "colour", desc=[(2213, "camper van", None, [r"parking lane"], None)])
add(A, "colour", "Post box in segment 2343 - colour? Don't want to drive past it",
    {"colour": "red"}, q_colour(1016), "colour", desc=[(1016, "post box", None, None, 2343)])

# ===== Voice B: city council clerk, formal written enquiries
B = "B-council-clerk"
add(B, "count", "I write on behalf of the Highways Committee, which, in preparation for its forthcoming review of street furniture, wishes to ascertain the total number of litter bins presently recorded across the whole of the mapped area; I should be grateful if you would supply that figure.",
    {"count": 19}, q_count("rubbish bin"), "count", label="rubbish bin")
add(B, "count", "Further to the Council's resolution on road signage, would you kindly confirm the number of speed limit signs that appear on the map in its entirety, including any that may stand at junctions?",
    {"count": 7}, q_count("speed limit sign"), "count", label="speed limit sign")
add(B, "count_within", "With reference to the signals maintenance budget, and so that the appropriate allocation may be made, could you state how many traffic lights are recorded within segment 2332?",
    {"count": 4}, q_count_within("traffic light", 2332), "count", label="traffic light")
add(B, "count_within", "The Fire Safety Officer, having received a complaint regarding access to water, has asked me to establish how many fire hydrants, if any, are situated within segment 2345; I would be obliged for a precise figure.",
    {"count": 0}, q_count_within("hydrant", 2345), "count", label="hydrant", segment_must_exist=2345)
add(B, "count_segments", "For the purposes of the resurfacing schedule, which distinguishes between straight stretches of carriageway and junctions of every description, I should be grateful to learn how many straight road segments the map contains.",
    {"count": 14}, q_count_segments(["straight_roadway"]), "count")
add(B, "count_segments", "The Traffic Management Sub-Committee requests the number of junctions at which three or more roads meet, by which it means T-junctions and crossroads taken together, but not those corners where a road merely bends. How many such junctions does the map show?",
    {"count": 5}, q_count_segments(["intersection", "t_intersection"]), "count")
add(B, "count_near", "In connection with a proposed programme of hydrant inspections, and taking as the reference point the position at which the survey vehicle commenced its recording, would you advise how many fire hydrants lie within 40 metres of that point?",
    {"count": 3}, q_distances("hydrant", ("start", None)), "near_count", radius=40, label="hydrant")
add(B, "count_near", "So that the Committee may assess the density of signage about the crossroads designated segment 2332, could you indicate how many speed limit signs stand within 50 metres of the centre of that segment?",
    {"count": 3}, q_distances("speed limit sign", ("segment", 2332)), "near_count", radius=50, label="speed limit sign")
add(B, "nearest", "Having regard to the place at which the survey vehicle began its recording, I am instructed to enquire which litter bin lies nearest to that place, and would ask that it be identified by its node id.",
    {"id": 836}, q_distances("rubbish bin", ("start", None)), "nearest", label="rubbish bin")
add(B, "nearest", "A resident living near segment 2345 has written to complain of the distance to the nearest posting facility; could you tell me which letter box is closest to the centre of that segment, giving its node id?",
    {"id": 452}, q_distances("letter box", ("segment", 2345)), "nearest", label="letter box")
add(B, "distance", "For the purposes of a planning consultation, would you be so kind as to state the straight-line distance, in metres, between the point at which the survey vehicle started recording and lane node 2357?",
    {"distance_m": 134.7}, q_pair(("start", None), ("lane", 2357)), "distance")
add(B, "distance", "I should be obliged if you would confirm, in metres and measured in a straight line, the distance that separates the fire hydrant bearing node id 1342 from the centre of segment 2335.",
    {"distance_m": 26.12}, q_pair(("object", 1342), ("segment", 2335)), "distance")
add(B, "route_length", "The Council's gritting contractor, whose vehicles must keep to the carriageway, has asked for the length of the shortest route along the lanes between lane node 2353 and lane node 2361; I should be grateful for that figure in metres.",
    {"length_m": 317.32}, Q_LANES, "route", src=2353, dst=2361)
add(B, "route_length", "Were a council vehicle to travel along the lane network from lane node 2354 to lane node 2360 by the shortest available route, what distance, expressed in metres, would it cover?",
    {"length_m": 255.88}, Q_LANES, "route", src=2354, dst=2360)
add(B, "segment", "Following a report that a yellow cast-iron fire hydrant has sustained damage, I am asked to identify the road segment in which that hydrant is located, and would be grateful for its segment id.",
    {"id": 2342}, q_segment(831), "segment", desc=[(831, "hydrant", "yellow", [r"cast-iron"], None)])
add(B, "segment", "A member of the public has drawn the Council's attention to a round black litter bin which is said to be overflowing; might you inform me in which segment that bin is situated?",
    {"id": 2344}, q_segment(1130), "segment", desc=[(1130, "bin", "black", [r"\bround\b"], None)])
add(B, "segment_kind", "In respect of the red and white speed limit sign which faces the oncoming traffic, could you confirm whether the section of road on which it stands is a crossroads, a T-junction, a bend or a straight road?",
    {"kind": "t_junction"}, q_segment(1277), "segment_kind",
    desc=[(1277, "speed limit sign", "red", [r"facing the traffic"], None)])
add(B, "segment_kind", "The Water Services Department wishes to know, with regard to the red cast-iron fire hydrant that stands on the sidewalk, what type of road segment it occupies, that is to say whether a crossroads, a T-junction, a bend or a straight road.",
    {"kind": "bend"}, q_segment(1439), "segment_kind",
    desc=[(1439, "hydrant", "red", [r"cast-iron", r"sidewalk"], None)])
add(B, "colour", "For the completion of the asset register, I would ask you to state the colour recorded for the fire hydrant that is located within segment 2338.",
    {"colour": "yellow"}, q_colour(14), "colour", desc=[(14, "hydrant", None, None, 2338)])
add(B, "colour", "The Cleansing Department, which is standardising the livery of its receptacles, has requested that I ascertain the colour of the litter bin situated in segment 2342; your assistance would be much appreciated.",
    {"colour": "orange"}, q_colour(836), "colour", desc=[(836, "bin", None, None, 2342)])

# ===== Voice C: wheelchair user planning a trip
C = "C-wheelchair-user"
add(C, "count", "I'm planning a day out in my wheelchair and I much prefer crossing where there are signals. How many traffic lights are there across the whole map?",
    {"count": 18}, q_count("traffic light"), "count", label="traffic light")
add(C, "count", "Hydrants are a real nuisance when the pavement's narrow and I'm in the chair. How many fire hydrants are there on the map altogether?",
    {"count": 9}, q_count("hydrant"), "count", label="hydrant")
add(C, "count_within", "I'll be rolling along segment 2341 tomorrow, and bins on the pavement can block my chair. How many rubbish bins are in that segment?",
    {"count": 2}, q_count_within("rubbish bin", 2341), "count", label="rubbish bin")
add(C, "count_within", "My friend says segment 2343 is always packed with parked cars, which makes the kerbs hard to reach. How many hatchbacks are actually in that segment?",
    {"count": 4}, q_count_within("hatchback", 2343), "count", label="hatchback")
add(C, "count_segments", "T-junctions are usually where I find the dropped kerbs. How many T-junctions does the map have?",
    {"count": 2}, q_count_segments(["t_intersection"]), "count")
add(C, "count_segments", "Big crossroads can be tricky for me to get across. How many proper crossroads, where four ways meet, are there?",
    {"count": 3}, q_count_segments(["intersection"]), "count")
add(C, "count_near", "I'm meeting a friend by the beige minibus that's parked in the parking lane. How many traffic lights are within 30 metres of it? I'd rather cross at signals.",
    {"count": 3}, q_distances("traffic light", ("object", 1897)), "near_count", radius=30, label="traffic light",
    desc=[(1897, "minibus", "beige", [r"parking lane"], None)])
add(C, "count_near", "I'll be waiting next to the silver scooter. How many mailboxes are within 40 metres of it? I've got letters to post and I don't want to wheel far.",
    {"count": 3}, q_distances("letter box", ("object", 1989)), "near_count", radius=40, label="letter box",
    desc=[(1989, "scooter", "silver", None, None)])
add(C, "nearest", "The accessible taxi is dropping me beside the silver camper van. Which traffic light is nearest to it? I'd like a signal-controlled crossing. Its id, please.",
    {"id": 1064}, q_distances("traffic light", ("object", 1054)), "nearest", label="traffic light",
    desc=[(1054, "camper van", "silver", None, None)])
add(C, "nearest", "That heavy blue scooter up on its kickstand, which bin is closest to it? The id would be great, I want to check it's not blocking the path.",
    {"id": 101}, q_distances("rubbish bin", ("object", 64)), "nearest", label="rubbish bin",
    desc=[(64, "scooter", "blue", [r"\bheavy\b"], None)])
add(C, "distance", "How far is it in a straight line from the green climbing frame to the beige minibus in the parking lane? I'm trying to judge whether I can wheel between them.",
    {"distance_m": 105.64}, q_pair(("object", 1073), ("object", 1897)), "distance",
    desc=[(1073, "climbing frame", "green", None, None), (1897, "minibus", "beige", [r"parking lane"], None)])
add(C, "distance", "Roughly how far is the silver scooter from lane node 2360, as the crow flies? In metres, please.",
    {"distance_m": 49.74}, q_pair(("object", 1989), ("lane", 2360)), "distance",
    desc=[(1989, "scooter", "silver", None, None)])
add(C, "route_length", "My wheelchair taxi has to stay on the lanes. What's the length of the shortest route from lane node 2355 to lane node 2362?",
    {"length_m": 171.16}, Q_LANES, "route", src=2355, dst=2362)
add(C, "route_length", "If the accessible bus takes the shortest way along the lanes from node 2359 to node 2360, how many metres is that?",
    {"length_m": 189.29}, Q_LANES, "route", src=2359, dst=2360)
add(C, "segment", "I use the black metal trash can as a landmark for where the kerb drops. Which segment is it in?",
    {"id": 2346}, q_segment(1533), "segment", desc=[(1533, "bin", "black", [r"\bmetal\b"], None)])
add(C, "segment", "There's an old white city bike parked on the sidewalk, and the ramp I use is right by it. What segment would that be?",
    {"id": 2340}, q_segment(404), "segment", desc=[(404, "bike", "white", [r"\bold\b", r"city bike"], None)])
add(C, "segment_kind", "The heavy motorbike parked at the roadside: is it on a straight road, a bend, a T-junction or a crossroads? Corners are harder for me to get round.",
    {"kind": "bend"}, q_segment(1392), "segment_kind", desc=[(1392, "motorbike", None, [r"\bheavy\b"], None)])
add(C, "segment_kind", "I'd love to take my niece to the green climbing frame. Is it on a straight stretch of road, a bend, a T-junction or a crossroads?",
    {"kind": "straight_road"}, q_segment(1073), "segment_kind", desc=[(1073, "climbing frame", "green", None, None)])
add(C, "colour", "There's a flat trailer left unhitched by the road that I'll need to get round. What colour is it, so I can spot it from a distance?",
    {"colour": "silver"}, q_colour(124), "colour", desc=[(124, "trailer", None, [r"\bflat\b"], None)])
add(C, "colour", "What colour is the hatchback in segment 2349? My friend's picking me up right by it.",
    {"colour": "black"}, q_colour(1303), "colour", desc=[(1303, "hatchback", None, None, 2349)])

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
    seg_ids = {r["id"] for r in run(Q_SEGS)}
    fails = []
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
