#!/usr/bin/env python3
"""Held-out question set 'indep4' over /work/main/out/city.og.

Usage:
    python3 gen.py --write   # (re)build questions.jsonl from SPECS, then verify
    python3 gen.py           # verify: re-run every stored cypher in questions.jsonl,
                             # re-derive each truth, run all uniqueness / margin checks,
                             # and assert the stored truth is reproduced exactly.

Only read-only Cypher through /tmp/opengraph_old is used; all geometry that
Cypher cannot express (Dijkstra over LANE edges) is done here in Python.
"""
import heapq
import json
import math
import re
import os
import subprocess
import sys

BIN = os.environ.get("OPENGRAPH", "opengraph")
DB = os.environ.get("OPENGRAPH_ASK_DB", "out/city.og")
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "questions.jsonl")

KIND_MAP = {
    "intersection": "crossroads",
    "t_intersection": "t_junction",
    "l_intersection": "bend",
    "straight_roadway": "straight_road",
}


def Q(cypher):
    out = subprocess.run([BIN, "query", "--db", DB, "--read-only", "--json", cypher],
                         capture_output=True, text=True, check=True).stdout
    # the binary appends "N row(s) in X ms" after the JSON array
    end = out.rfind("]")
    return json.loads(out[: end + 1])


# ---------------------------------------------------------------- cypher snippets
def dist_expr(a, b):
    """ground distance between two {x,y,z} expressions (y ignored)."""
    return f"sqrt(({a}.x - {b}.x)^2 + ({a}.z - {b}.z)^2)"


START = "MATCH (f:Frame) WITH f ORDER BY f.index ASC LIMIT 1 "
END = "MATCH (f:Frame) WITH f ORDER BY f.index DESC LIMIT 1 "


def dist_to_frame(p):
    return f"sqrt(({p}.x - f.world_from_velo[3])^2 + ({p}.z - f.world_from_velo[11])^2)"


# Described (unique) objects: a Cypher predicate over label / colour on the
# Instance bound to `var`, plus an independent caption-based uniqueness check.
DESC = {
    "silver_hydrant": dict(id=922, pred="{v}.label = 'hydrant' AND {v}.colour = 'silver'",
                           cap=["hydrant", "silver"]),
    "red_delivery_truck": dict(id=998, pred="{v}.label = 'delivery truck' AND {v}.colour = 'red'",
                               cap=["delivery truck", "red"]),
    "green_climbing_frame": dict(id=1108, pred="{v}.label = 'climbing frame' AND {v}.colour = 'green'",
                                 cap=["climbing frame", "green"]),
    "blue_camper_van": dict(id=428, pred="{v}.label = 'camper van' AND {v}.colour = 'blue'",
                            cap=["camper van", "blue"]),
    "silver_camper_van": dict(id=1089, pred="{v}.label = 'camper van' AND {v}.colour = 'silver'",
                              cap=["camper van", "silver"]),
    "blue_scooter": dict(id=64, pred="{v}.label = 'scooter' AND {v}.colour = 'blue'",
                         cap=["scooter", "blue"]),
    "silver_scooter": dict(id=2059, pred="{v}.label = 'scooter' AND {v}.colour = 'silver'",
                           cap=["scooter", "silver"]),
    "rw_speed_sign_facing": dict(id=1317,
                                 pred="{v}.label = 'speed limit sign' AND any(c IN {v}.captions WHERE c CONTAINS 'red and white' AND c CONTAINS 'facing the traffic')",
                                 cap=["speed limit", "red and white", "facing the traffic"]),
    "round_green_plastic_bin": dict(id=1303,
                                    pred="{v}.label = 'rubbish bin' AND {v}.colour = 'green' AND any(c IN {v}.captions WHERE c CONTAINS 'round' AND c CONTAINS 'plastic')",
                                    cap=["round", "green", "plastic", "bin"]),
    "grey_signal_showing_green": dict(id=1097,
                                      pred="{v}.label = 'traffic light' AND {v}.colour = 'grey' AND any(c IN {v}.captions WHERE c CONTAINS 'showing green')",
                                      cap=["grey", "showing green"]),
    "red_castiron_hydrant_sidewalk": dict(id=1481,
                                          pred="{v}.label = 'hydrant' AND {v}.colour = 'red' AND any(c IN {v}.captions WHERE c CONTAINS 'cast-iron' AND c CONTAINS 'on the sidewalk')",
                                          cap=["hydrant", "red", "cast-iron", "on the sidewalk"]),
    "cargo_trailer_curb": dict(id=86,
                               pred="{v}.label = 'trailer' AND any(c IN {v}.captions WHERE c CONTAINS 'cargo trailer' AND c CONTAINS 'parked by the curb')",
                               cap=["cargo trailer", "parked by the curb"]),
    "box_truck": dict(id=2127, pred="{v}.label = 'box truck unloading'", cap=["box truck"]),
    "obj86": dict(id=86, pred="id({v}) = 86", cap=None),
}


def obj_pred(key, v="a"):
    return DESC[key]["pred"].format(v=v)


# -------------------------------------------------------------------- specs
# voice: T = hurried field technician texting, E = polite elderly resident,
#        A = data analyst writing spec-like requests
SPECS = []


def add(kind, voice, q, cypher, **kw):
    SPECS.append(dict(kind=kind, voice=voice, question=q, cypher=cypher, **kw))


# ---- count (whole map, by Instance.label)
def c_count(label):
    return f"MATCH (n:Instance) WHERE n.label = '{label}' RETURN count(n) AS c"


# caption keywords per counted label: used to cross-check that label-based counts
# equal caption-based counts (no mislabelled objects of the kind hiding elsewhere).
CAP_WORDS = {
    "hydrant": ["hydrant"],
    "letter box": ["letter box", "mailbox", "post box"],
    "rubbish bin": ["rubbish bin", "trash can", "litter bin"],
    "bench": ["bench"],
    "trailer": ["trailer"],
    "traffic light": ["traffic light", "traffic signal"],
    "hatchback": ["hatchback"],
}
# captions of bus stops / shelters say "with a bench inside": not benches
CAP_EXCLUDE = ["bench inside"]


add("count", "T", "hw many fire hydrants r there on the whole map? total nr pls", c_count("hydrant"))
add("count", "E", "I do hope you'll forgive an old woman's curiosity, but I have always wondered, taking the "
    "entire map into account from one end to the other, just how many post boxes there are for "
    "posting one's letters?", c_count("letter box"))
add("count", "A", "Return the total count of rubbish bins (trash cans / litter bins) across the entire map.",
    c_count("rubbish bin"))
add("count", "T", "total nr of benches on the map? need it asap", c_count("bench"))
add("count", "E", "My late husband used to tow a little trailer behind our car, which is perhaps why I notice "
    "them so; could you tell me how many trailers have been recorded across the whole of the map?",
    c_count("trailer"))
add("count", "A", "Output the number of traffic lights (traffic signals) present on the full map.",
    c_count("traffic light"))


# ---- count_within (objects of a kind in one segment)
def c_within(label, seg):
    return (f"MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE id(s) = {seg} AND n.label = '{label}' "
            f"RETURN count(n) AS c")


add("count_within", "A", "Return the count of benches located in segment 2412.", c_within("bench", 2412),
    seg_kind_check=(2412, None))
add("count_within", "T", "seg 2423 - how many hatchbacks in there?", c_within("hatchback", 2423))
add("count_within", "E", "The four-way crossing that is segment number 2406 always seems so full of signals to me; "
    "would you be so kind as to count how many traffic lights stand within that segment?",
    c_within("traffic light", 2406), seg_kind_check=(2406, "crossroads"))
add("count_within", "T", "how many bins/trash cans in segment no. 2421?", c_within("rubbish bin", 2421))
add("count_within", "E", "I post a great many letters, you see, and I am told segment 2416 is rather well served; "
    "how many letterboxes are there in that particular segment, if you'd be so good?",
    c_within("letter box", 2416))
add("count_within", "A", "Compute the number of fire hydrants inside segment id 2413.", c_within("hydrant", 2413))

# ---- count_segments
add("count_segments", "T", "how many road segments total on the map, all kinds?",
    "MATCH (s:Segment) RETURN count(s) AS c")
add("count_segments", "E", "Forgive me, I do get so muddled at the big crossings. How many proper four-way "
    "crossroads are there on the map altogether?",
    "MATCH (s:Segment) WHERE s.kind = 'intersection' RETURN count(s) AS c")
add("count_segments", "A", "Return the number of segments whose kind is T-junction (three-way intersection).",
    "MATCH (s:Segment) WHERE s.kind = 't_intersection' RETURN count(s) AS c")
add("count_segments", "T", "nr of bend / corner segs on the map?",
    "MATCH (s:Segment) WHERE s.kind = 'l_intersection' RETURN count(s) AS c")
add("count_segments", "E", "And how many of the segments are simply straight stretches of road, with no junction "
    "or corner to speak of, if you would be so kind?",
    "MATCH (s:Segment) WHERE s.kind = 'straight_roadway' RETURN count(s) AS c")
add("count_segments", "A", "Count the segments that are either crossroads or T-junctions (exclude bends and "
    "straight road sections).",
    "MATCH (s:Segment) WHERE s.kind = 'intersection' OR s.kind = 't_intersection' RETURN count(s) AS c")


# ---- count_near (truth cypher counts with d <= R; margin cypher lists all distances)
def near_frame(which, label, R, count=True):
    pre = START if which == "start" else END
    base = f"{pre}MATCH (n:Instance) WHERE n.label = '{label}' WITH n, {dist_to_frame('n.centroid')} AS d "
    return base + (f"WHERE d <= {R} RETURN count(n) AS c" if count else "RETURN id(n) AS id, d ORDER BY d")


def near_seg(seg, label, R, count=True):
    base = (f"MATCH (s:Segment), (n:Instance) WHERE id(s) = {seg} AND n.label = '{label}' "
            f"WITH n, {dist_expr('n.centroid', 's.centroid')} AS d ")
    return base + (f"WHERE d <= {R} RETURN count(n) AS c" if count else "RETURN id(n) AS id, d ORDER BY d")


def near_obj(key, label, R, count=True):
    base = (f"MATCH (a:Instance), (n:Instance) WHERE {obj_pred(key)} AND n.label = '{label}' AND id(n) <> id(a) "
            f"WITH n, {dist_expr('n.centroid', 'a.centroid')} AS d ")
    return base + (f"WHERE d <= {R} RETURN count(n) AS c" if count else "RETURN id(n) AS id, d ORDER BY d")


add("count_near", "T", "hydrants within 40 m of where the drive started - how many?",
    near_frame("start", "hydrant", 40.0), radius=40.0, margin=near_frame("start", "hydrant", 40.0, False))
add("count_near", "E", "When the drive came to its end, I imagine there were benches about for a weary traveller; "
    "how many benches lie within 50 metres of the spot where the drive finished?",
    near_frame("end", "bench", 50.0), radius=50.0, margin=near_frame("end", "bench", 50.0, False))
add("count_near", "A", "Return the number of letter boxes whose ground distance to the centroid of segment 2406 "
    "is at most 25 m.", near_seg(2406, "letter box", 25.0), radius=25.0,
    margin=near_seg(2406, "letter box", 25.0, False))
add("count_near", "T", "benches w/in 30m of seg 2404 centre? count pls", near_seg(2404, "bench", 30.0),
    radius=30.0, margin=near_seg(2404, "bench", 30.0, False))
add("count_near", "E", "There is a big red delivery truck I have noticed parked along the kerb; could you tell me "
    "how many hatchbacks are within 40 metres of it, please?",
    near_obj("red_delivery_truck", "hatchback", 40.0), radius=40.0, anchor="red_delivery_truck",
    margin=near_obj("red_delivery_truck", "hatchback", 40.0, False))
add("count_near", "A", "Count the utility poles within a 30 m ground radius of the blue camper van.",
    near_obj("blue_camper_van", "utility pole", 30.0), radius=30.0, anchor="blue_camper_van",
    margin=near_obj("blue_camper_van", "utility pole", 30.0, False))


# ---- nearest (cypher returns the two closest; margin >= 0.5 m asserted)
def nn_frame(which, label):
    pre = START if which == "start" else END
    return (f"{pre}MATCH (n:Instance) WHERE n.label = '{label}' "
            f"RETURN id(n) AS id, {dist_to_frame('n.centroid')} AS d ORDER BY d ASC LIMIT 2")


def nn_seg(seg, label):
    return (f"MATCH (s:Segment), (n:Instance) WHERE id(s) = {seg} AND n.label = '{label}' "
            f"RETURN id(n) AS id, {dist_expr('n.centroid', 's.centroid')} AS d ORDER BY d ASC LIMIT 2")


def nn_obj(key, label):
    return (f"MATCH (a:Instance), (n:Instance) WHERE {obj_pred(key)} AND n.label = '{label}' AND id(n) <> id(a) "
            f"RETURN id(n) AS id, {dist_expr('n.centroid', 'a.centroid')} AS d ORDER BY d ASC LIMIT 2")


add("nearest", "A", "Output the node id of the fire hydrant nearest to the start of the drive.",
    nn_frame("start", "hydrant"))
add("nearest", "T", "closest trafic light to the end of the drive? need obj id", nn_frame("end", "traffic light"))
add("nearest", "E", "Near the crossroads that is segment 2404 there are a few places to sit, I believe. Which "
    "bench is the closest one to that crossing? Its id number would be ever so helpful.",
    nn_seg(2404, "bench"), seg_kind_check=(2404, "crossroads"))
add("nearest", "T", "nearest utility pole to seg 2418, id?", nn_seg(2418, "utility pole"))
add("nearest", "E", "Were I standing beside that large red delivery truck, which hatchback would be the nearest "
    "to me? Do give me its id, if you would.", nn_obj("red_delivery_truck", "hatchback"),
    anchor="red_delivery_truck")
add("nearest", "A", "Return the id of the letter box nearest to the green climbing frame.",
    nn_obj("green_climbing_frame", "letter box"), anchor="green_climbing_frame")

# ---- distance
add("distance", "T", "dist from drive start to drive end, straight line, in m?",
    "MATCH (f0:Frame) WITH min(f0.index) AS i0, max(f0.index) AS i1 "
    "MATCH (a:Frame {index: i0}), (b:Frame {index: i1}) "
    "RETURN sqrt((a.world_from_velo[3] - b.world_from_velo[3])^2 + (a.world_from_velo[11] - b.world_from_velo[11])^2) AS d")
add("distance", "E", "How far apart would you say the middle of segment 2401 is from the middle of segment 2406, "
    "as the crow flies over the ground, I mean, and not by the roads?",
    f"MATCH (a:Segment), (b:Segment) WHERE id(a) = 2401 AND id(b) = 2406 RETURN {dist_expr('a.centroid', 'b.centroid')} AS d")
add("distance", "A", "Compute the straight-line ground distance in metres between the silver fire hydrant and the "
    "red delivery truck.",
    f"MATCH (a:Instance), (b:Instance) WHERE {obj_pred('silver_hydrant', 'a')} AND {obj_pred('red_delivery_truck', 'b')} "
    f"RETURN {dist_expr('a.centroid', 'b.centroid')} AS d", anchor=["silver_hydrant", "red_delivery_truck"])
add("distance", "T", "approx dist from the drive start to the green climbing frame? metres",
    f"{START}MATCH (a:Instance) WHERE {obj_pred('green_climbing_frame')} RETURN {dist_to_frame('a.centroid')} AS d",
    anchor="green_climbing_frame")
add("distance", "E", "I've been told the recorded drive came to an end not far from where I do my shopping. "
    "How far, in a straight line over the ground, is the point where the drive finished from the centre "
    "of segment no. 2423?",
    f"{END}MATCH (s:Segment) WHERE id(s) = 2423 RETURN {dist_to_frame('s.centroid')} AS d")
add("distance", "A", "Compute the ground distance between obj 86 and the centroid of segment 2410.",
    f"MATCH (a:Instance), (s:Segment) WHERE id(a) = 86 AND id(s) = 2410 RETURN {dist_expr('a.centroid', 's.centroid')} AS d")

# ---- route_length (Dijkstra in Python over the undirected LANE edge list)
LANE_EDGES = ("MATCH (a:LaneNode)-[r:LANE]->(b:LaneNode) "
              "RETURN id(a) AS a, id(b) AS b, r.length_m AS w")
add("route_length", "A", "Compute the lane-graph shortest path length in metres between lane node 2425 and "
    "lane node 2432.", LANE_EDGES, route=(2425, 2432))
add("route_length", "T", "route len lane 2434 -> lane 2433 following the lanes? m", LANE_EDGES, route=(2434, 2433))
add("route_length", "E", "If one were to drive along the lanes, rather than cutting across country as it were, "
    "how far would it be from lane node 2426 to lane node 2429?", LANE_EDGES, route=(2426, 2429))
add("route_length", "T", "driving dist via lane graph, node 2431 to node 2428, shortst?", LANE_EDGES,
    route=(2431, 2428))
add("route_length", "E", "I should like to know, please, the shortest distance by road, keeping to the lane "
    "network, between lane 2424 and lane 2430.", LANE_EDGES, route=(2424, 2430))
add("route_length", "A", "Return the shortest-path length over LANE edges from lane node 2433 to lane node 2425, "
    "in metres.", LANE_EDGES, route=(2433, 2425))


# ---- segment
def seg_of(key):
    return (f"MATCH (a:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE {obj_pred(key)} "
            f"RETURN id(a) AS obj, id(s) AS seg, s.kind AS kind, a.colour AS colour")


add("segment", "T", "whcih seg is the silver fire hydrant in? seg id pls", seg_of("silver_hydrant"),
    anchor="silver_hydrant")
add("segment", "E", "That large red delivery truck I keep mentioning, the one along the kerb; in which segment "
    "is it parked, would you know?", seg_of("red_delivery_truck"), anchor="red_delivery_truck")
add("segment", "A", "Output the segment id containing the green wooden climbing frame.", seg_of("green_climbing_frame"),
    anchor="green_climbing_frame")
add("segment", "T", "silver camper van - what segment is it in?", seg_of("silver_camper_van"),
    anchor="silver_camper_van")
add("segment", "E", "There's a heavy blue scooter standing on its kickstand that I pass on my walks; which segment "
    "of the map would that be in, dear?", seg_of("blue_scooter"), anchor="blue_scooter")
add("segment", "A", "Return the segment id of the round red-and-white speed limit sign facing the traffic.",
    seg_of("rw_speed_sign_facing"), anchor="rw_speed_sign_facing")

# ---- segment_kind
add("segment_kind", "E", "There is a round green plastic rubbish bin, quite full of rubbish I'm sorry to say; "
    "what sort of road is it on: a crossroads, a T-junction, a bend, or just a straight bit?",
    seg_of("round_green_plastic_bin"), anchor="round_green_plastic_bin")
add("segment_kind", "A", "Return the road type (crossroads / T-junction / bend / straight road) of the segment "
    "containing the grey traffic signal that is showing green.", seg_of("grey_signal_showing_green"),
    anchor="grey_signal_showing_green")
add("segment_kind", "T", "red cast-iron hydrant on the sidewalk - what kind of rd is it on? 4-way, T, corner or "
    "straight?", seg_of("red_castiron_hydrant_sidewalk"), anchor="red_castiron_hydrant_sidewalk")
add("segment_kind", "E", "I have seen a long silver cargo trailer parked by the curb; is that on a four-way "
    "crossing, a three-way junction, a corner, or a straight section of road?", seg_of("cargo_trailer_curb"),
    anchor="cargo_trailer_curb")
add("segment_kind", "T", "silver scooter - on a junction or straight rd? which type", seg_of("silver_scooter"),
    anchor="silver_scooter")
add("segment_kind", "A", "Output the segment kind (crossroads, T-junction, bend or straight road) where the blue "
    "camper van is located.", seg_of("blue_camper_van"), anchor="blue_camper_van")


# ---- colour (object unique by label within a segment; colour property non-null, captions agree)
def colour_in_seg(label, seg):
    return (f"MATCH (a:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE id(s) = {seg} AND a.label = '{label}' "
            f"RETURN id(a) AS obj, a.colour AS colour")


add("colour", "T", "colour of the hydrant in seg 2418?", colour_in_seg("hydrant", 2418),
    cap_unique=(2418, ["hydrant"]))
add("colour", "E", "There's a letterbox in segment 2422 where I sometimes post my cards; could you remind me "
    "what colour it's painted?", colour_in_seg("letter box", 2422),
    cap_unique=(2422, ["letter box", "mailbox", "post box"]))
add("colour", "A", "Return the colour of the rubbish bin located in segment 2414.", colour_in_seg("rubbish bin", 2414),
    cap_unique=(2414, ["rubbish bin", "trash can", "litter bin"]))
add("colour", "T", "hatchback in seg 2420 - what colour?", colour_in_seg("hatchback", 2420),
    cap_unique=(2420, ["hatchback"]))
add("colour", "E", "Would you happen to know what colour the camper van in segment 2423 is? I rather fancy one "
    "myself.", colour_in_seg("camper van", 2423), cap_unique=(2423, ["camper van"]))
add("colour", "A", "Output the colour of the box truck unloading at the roadside.",
    "MATCH (a:Instance) WHERE a.label = 'box truck unloading' RETURN id(a) AS obj, a.colour AS colour",
    anchor="box_truck")


# ------------------------------------------------------------------ derive
def dijkstra(edges, s, t):
    g = {}
    for e in edges:
        g.setdefault(e["a"], []).append((e["b"], e["w"]))
        g.setdefault(e["b"], []).append((e["a"], e["w"]))
    dist = {s: 0.0}
    pq = [(0.0, s)]
    while pq:
        d, u = heapq.heappop(pq)
        if d > dist[u]:
            continue
        if u == t:
            return d
        for v, w in g.get(u, []):
            if d + w < dist.get(v, math.inf):
                dist[v] = d + w
                heapq.heappush(pq, (d + w, v))
    raise AssertionError(f"no route {s}->{t}")


def check_anchor(key):
    d = DESC[key]
    rows = Q(f"MATCH (a:Instance) WHERE {obj_pred(key)} RETURN id(a) AS id")
    assert [r["id"] for r in rows] == [d["id"]], (key, rows)
    if d["cap"]:
        # caption-based uniqueness: no other instance has a caption holding all keywords
        conds = " AND ".join(f"c CONTAINS '{w}'" for w in d["cap"])
        rows = Q(f"MATCH (a:Instance) WHERE any(c IN a.captions WHERE {conds}) RETURN id(a) AS id")
        assert sorted(r["id"] for r in rows) == [d["id"]], (key, "caption uniqueness", rows)


def derive(spec):
    kind = spec["kind"]
    rows = Q(spec["cypher"])
    if kind in ("count", "count_within", "count_segments", "count_near"):
        assert len(rows) == 1
        if kind in ("count", "count_within"):
            label = re.search(r"n\.label = '([^']+)'", spec["cypher"]).group(1)
            seg = re.search(r"id\(s\) = (\d+)", spec["cypher"])
            conds = " OR ".join(f"c CONTAINS '{w}'" for w in CAP_WORDS[label])
            excl = " AND ".join(f"NOT c CONTAINS '{w}'" for w in CAP_EXCLUDE)
            cq = (f"MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE "
                  + (f"id(s) = {seg.group(1)} AND " if seg else "")
                  + f"any(c IN n.captions WHERE ({conds}) AND {excl}) RETURN id(n) AS id, n.label AS label")
            cap_rows = Q(cq)
            assert all(r["label"] == label for r in cap_rows), ("caption/label disagreement", cap_rows)
            assert len(cap_rows) == rows[0]["c"], ("caption-based count differs", len(cap_rows), rows[0]["c"])
        if kind == "count_near":
            ds = [r["d"] for r in Q(spec["margin"])]
            R = spec["radius"]
            assert all(abs(x - R) >= 1.0 for x in ds), ("radius margin", spec["question"])
            assert sum(1 for x in ds if x <= R) == rows[0]["c"]
        return {"count": int(rows[0]["c"])}
    if kind == "nearest":
        assert len(rows) == 2
        assert rows[1]["d"] - rows[0]["d"] >= 0.5, ("nearest margin", spec["question"], rows)
        return {"id": rows[0]["id"]}
    if kind == "distance":
        assert len(rows) == 1
        return {"metres": round(rows[0]["d"], 2)}
    if kind == "route_length":
        s, t = spec["route"]
        return {"metres": round(dijkstra(rows, s, t), 2)}
    if kind == "segment":
        assert len(rows) == 1
        return {"segment": rows[0]["seg"]}
    if kind == "segment_kind":
        assert len(rows) == 1
        return {"segment_kind": KIND_MAP[rows[0]["kind"]]}
    if kind == "colour":
        assert len(rows) == 1, rows
        col = rows[0]["colour"]
        assert col, "null colour"
        caps = Q(f"MATCH (a:Instance) WHERE id(a) = {rows[0]['obj']} RETURN a.captions AS c")[0]["c"]
        assert caps and all(col in c for c in caps), ("captions disagree with colour", caps)
        if "cap_unique" in spec:
            seg, words = spec["cap_unique"]
            conds = " OR ".join(f"c CONTAINS '{w}'" for w in words)
            ids = Q(f"MATCH (a:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE id(s) = {seg} AND "
                    f"any(c IN a.captions WHERE {conds}) RETURN id(a) AS id")
            assert [r["id"] for r in ids] == [rows[0]["obj"]], ("caption uniqueness in segment", ids)
        return {"colour": col}
    raise ValueError(kind)


def extra_checks(spec):
    anchors = spec.get("anchor")
    if anchors:
        for k in ([anchors] if isinstance(anchors, str) else anchors):
            check_anchor(k)
    if spec.get("seg_kind_check") and spec["seg_kind_check"][1]:
        seg, want = spec["seg_kind_check"]
        k = Q(f"MATCH (s:Segment) WHERE id(s) = {seg} RETURN s.kind AS k")[0]["k"]
        assert KIND_MAP[k] == want, (seg, k, want)


def main():
    by_q = {s["question"]: s for s in SPECS}
    assert len(by_q) == len(SPECS) == 60
    if "--write" in sys.argv:
        with open(OUT, "w") as fh:
            for s in SPECS:
                truth = derive(s)
                fh.write(json.dumps({"kind": s["kind"], "question": s["question"], "truth": truth,
                                     "cypher": s["cypher"]}) + "\n")
        print(f"wrote {OUT}")
    lines = [json.loads(l) for l in open(OUT)]
    assert len(lines) == 60
    from collections import Counter
    kinds = Counter(l["kind"] for l in lines)
    assert all(v == 6 for v in kinds.values()) and len(kinds) == 10, kinds
    voices = Counter(by_q[l["question"]]["voice"] for l in lines)
    ok = 0
    for l in lines:
        spec = dict(by_q[l["question"]])
        spec["cypher"] = l["cypher"]  # re-run the *stored* cypher
        extra_checks(spec)
        t = derive(spec)
        assert t == l["truth"], (l["question"], t, l["truth"])
        ok += 1
    print(f"verified {ok}/60 truths; kinds={dict(kinds)}; voices={dict(voices)}")


if __name__ == "__main__":
    main()
