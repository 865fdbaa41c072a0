#!/usr/bin/env python3
"""Independent held-out question set "indep5" for the city scene-graph map.

Usage:
    python3 gen.py            # verify: re-run every stored cypher in questions.jsonl,
                              # re-derive each truth, run all uniqueness/margin/label audits
    python3 gen.py --write    # (re)build questions.jsonl from SPEC below, then verify

Environment:
    OPENGRAPH         query binary   (default opengraph)
    OPENGRAPH_ASK_DB  database path  (default out/city.og)

Only read-only `query` calls are made.
"""
import heapq
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
QFILE = os.path.join(HERE, "questions.jsonl")
OG = os.environ.get("OPENGRAPH", "opengraph")
DB = os.environ.get("OPENGRAPH_ASK_DB", "out/city.og")

KIND_MAP = {
    "intersection": "crossroads",
    "t_intersection": "t_junction",
    "l_intersection": "bend",
    "straight_roadway": "straight_road",
}
COLOUR_WORDS = {"white", "black", "grey", "red", "blue", "green", "yellow",
                "silver", "brown", "beige", "orange"}

_cache = {}


def q(cypher):
    if cypher in _cache:
        return _cache[cypher]
    p = subprocess.run([OG, "query", "--db", DB, "--read-only", "--json", cypher],
                       capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError("query failed: %s\n%s" % (cypher, p.stderr))
    rows = json.loads(p.stdout)
    _cache[cypher] = rows
    return rows


def r2(x):
    return round(float(x) + 0.0, 2)


# ---------------------------------------------------------------- derivation
def derive(kind, rows):
    """Derive (truth, info) from the rows of a question's stored cypher.
    info carries the id of the described object (if any) for the audits."""
    info = {}
    if kind in ("count", "count_within", "count_segments"):
        assert len(rows) == 1, rows
        return {"count": int(rows[0]["count"])}, info

    if kind in ("count_near", "nearest"):
        refs = {json.dumps(r["ref"]) for r in rows}
        assert len(refs) == 1, "reference is not unique: %s" % refs
        info["ref"] = rows[0]["ref"]
        dl = sorted((math.hypot(r["x"] - r["rx"], r["z"] - r["rz"]), r["id"]) for r in rows)
        assert len({i for _, i in dl}) == len(dl), "duplicate candidates"
        if kind == "count_near":
            R = float(rows[0]["radius"])
            assert len({float(r["radius"]) for r in rows}) == 1
            close = [(d, i) for d, i in dl if abs(d - R) < 1.0]
            assert not close, "object within 1 m of the radius boundary: %s" % close
            return {"count": sum(1 for d, _ in dl if d <= R)}, info
        # nearest: exclude the reference itself if it happens to be a candidate
        dl = [(d, i) for d, i in dl if i != info["ref"]]
        assert len(dl) >= 2
        assert dl[1][0] - dl[0][0] >= 0.5, "nearest margin < 0.5 m: %s" % dl[:2]
        info["margin"] = dl[1][0] - dl[0][0]
        info["nearest_d"] = dl[0][0]
        return {"id": dl[0][1]}, info

    if kind == "distance":
        assert len(rows) == 1, "endpoints not unique: %d rows" % len(rows)
        r = rows[0]
        info.update({k: r[k] for k in ("a", "b") if k in r})
        return {"metres": r2(math.hypot(r["ax"] - r["bx"], r["az"] - r["bz"]))}, info

    if kind == "route_length":
        src, dst = rows[0]["src"], rows[0]["dst"]
        adj = {}
        for r in rows:
            assert r["src"] == src and r["dst"] == dst
            adj.setdefault(r["a"], []).append((r["b"], float(r["w"])))
            adj.setdefault(r["b"], []).append((r["a"], float(r["w"])))
        assert src in adj and dst in adj
        dist = {src: 0.0}
        pq = [(0.0, src)]
        while pq:
            d, u = heapq.heappop(pq)
            if d > dist.get(u, math.inf):
                continue
            for v, w in adj[u]:
                nd = d + w
                if nd < dist.get(v, math.inf):
                    dist[v] = nd
                    heapq.heappush(pq, (nd, v))
        return {"metres": r2(dist[dst])}, info

    if kind == "segment":
        assert len(rows) == 1, "described object not unique: %d rows" % len(rows)
        info["obj"] = rows[0]["id"]
        return {"segment": rows[0]["seg"]}, info

    if kind == "segment_kind":
        assert len(rows) == 1, "described object not unique: %d rows" % len(rows)
        info["obj"] = rows[0]["id"]
        return {"segment_kind": KIND_MAP[rows[0]["kind"]]}, info

    if kind == "colour":
        assert len(rows) == 1, "described object not unique: %d rows" % len(rows)
        r = rows[0]
        info["obj"] = r["id"]
        c = r["colour"]
        assert c is not None and c in COLOUR_WORDS, c
        for cap in r["captions"]:
            words = {w for w in COLOUR_WORDS if w in cap.lower().replace("red-brick", "brick")}
            assert words == {c}, "caption disagrees with colour %s: %r" % (c, cap)
        return {"colour": c}, info

    raise ValueError(kind)


# ---------------------------------------------------------------- audits
AUDIT_CYPHER = ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE n.label IS NOT NULL "
                "RETURN id(n) AS id, n.label AS label, n.colour AS colour, "
                "n.captions AS captions, id(s) AS seg")


def objects():
    return q(AUDIT_CYPHER)


def _strip(cap, excludes):
    c = cap.lower()
    for e in excludes:
        c = c.replace(e, "")
    return c


def audit_label(label, nouns, excludes=(), seg=None):
    """Counting audit: inside the scope, every instance with `label` has all captions
    naming one of `nouns`, and no instance with another label has a caption naming one."""
    n_lab = 0
    for o in objects():
        if seg is not None and o["seg"] != seg:
            continue
        caps = [_strip(c, excludes) for c in (o["captions"] or [])]
        hit = [c for c in caps if any(nn in c for nn in nouns)]
        if o["label"] == label:
            n_lab += 1
            assert len(hit) == len(caps), "label %s id %s has off-label captions" % (label, o["id"])
        else:
            assert not hit, "id %s (label %s) has a caption naming %s: %s" % (
                o["id"], o["label"], nouns, hit[:2])
    return n_lab


def audit_unique(expect_id, label, nouns, attrs=(), seg=None):
    """Description audit: the broad reading of the description (label OR caption noun,
    each attribute via colour property OR any caption) matches exactly one object."""
    found = []
    for o in objects():
        if seg is not None and o["seg"] != seg:
            continue
        caps = [c.lower() for c in (o["captions"] or [])]
        noun_ok = o["label"] == label or any(nn in c for c in caps for nn in nouns)
        if not noun_ok:
            continue
        ok = all((o["colour"] == a) or any(a in c for c in caps) for a in attrs)
        if ok:
            found.append(o["id"])
    assert found == [expect_id], "description %s %s %s matches %s (expected %s)" % (
        label, attrs, seg, found, expect_id)


# ---------------------------------------------------------------- question spec
START = "MATCH (f:Frame) WITH min(f.index) AS m MATCH (g:Frame), (n:Instance) WHERE g.index = m AND "
END = "MATCH (f:Frame) WITH max(f.index) AS m MATCH (g:Frame), (n:Instance) WHERE g.index = m AND "
FRAME_RET = "RETURN g.index AS ref, g.world_from_velo[3] AS rx, g.world_from_velo[11] AS rz, "
CAND_RET = "id(n) AS id, n.centroid.x AS x, n.centroid.z AS z"
ROUTE = ("MATCH (a:LaneNode)-[r:LANE]->(b:LaneNode) "
         "RETURN id(a) AS a, id(b) AS b, r.length_m AS w, %d AS src, %d AS dst")


def seg_near(seg, label, radius=None):
    rad = "%.1f AS radius, " % radius if radius is not None else ""
    return ("MATCH (s:Segment), (n:Instance) WHERE id(s) = %d AND n.label = '%s' "
            "RETURN id(s) AS ref, s.centroid.x AS rx, s.centroid.z AS rz, %s%s"
            % (seg, label, rad, CAND_RET))


def obj_near(ref_pred, label, radius=None):
    rad = "%.1f AS radius, " % radius if radius is not None else ""
    return ("MATCH (a:Instance), (n:Instance) WHERE %s AND n.label = '%s' "
            "RETURN id(a) AS ref, a.centroid.x AS rx, a.centroid.z AS rz, %s%s"
            % (ref_pred, label, rad, CAND_RET))


def frame_near(which, label, radius=None):
    rad = "%.1f AS radius, " % radius if radius is not None else ""
    return (START if which == "start" else END) + "n.label = '%s' " % label + FRAME_RET + rad + CAND_RET


# Descriptions of objects (narrow cypher predicate on variable `a`/`n`, plus audit data)
D = {
    "climbing_frame": dict(label="climbing frame", nouns=["climbing frame"], attrs=["green"],
                           pred="{v}.label = 'climbing frame' AND {v}.colour = 'green'"),
    "red_truck": dict(label="delivery truck", nouns=["delivery truck"], attrs=["red"],
                      pred="{v}.label = 'delivery truck' AND {v}.colour = 'red'"),
    "blue_scooter": dict(label="scooter", nouns=["scooter"], attrs=["blue"],
                         pred="{v}.label = 'scooter' AND {v}.colour = 'blue'"),
    "beige_camper": dict(label="camper van", nouns=["camper van", "camper"], attrs=["beige"],
                         pred="{v}.label = 'camper van' AND {v}.colour = 'beige'"),
    "black_hatch": dict(label="hatchback", nouns=["hatchback"], attrs=["black", "dusty windows"],
                        pred="{v}.label = 'hatchback' AND {v}.colour = 'black' "
                             "AND any(c IN {v}.captions WHERE c CONTAINS 'dusty windows')"),
    "silver_hydrant": dict(label="hydrant", nouns=["hydrant"], attrs=["silver"],
                           pred="{v}.label = 'hydrant' AND {v}.colour = 'silver'"),
    "rw_sign": dict(label="speed limit sign", nouns=["speed limit"],
                    attrs=["red and white", "facing the traffic"],
                    pred="{v}.label = 'speed limit sign' AND any(c IN {v}.captions WHERE c CONTAINS 'red and white') "
                         "AND any(c IN {v}.captions WHERE c CONTAINS 'facing the traffic')"),
    "castiron_hydrant": dict(label="hydrant", nouns=["hydrant"], attrs=["red", "cast-iron", "on the sidewalk"],
                             pred="{v}.label = 'hydrant' AND {v}.colour = 'red' "
                                  "AND any(c IN {v}.captions WHERE c CONTAINS 'cast-iron') "
                                  "AND any(c IN {v}.captions WHERE c CONTAINS 'on the sidewalk')"),
    "trimmed_hedge": dict(label="hedge", nouns=["hedge"], attrs=["trimmed", "along a garden"],
                          pred="{v}.label = 'hedge' AND any(c IN {v}.captions WHERE c CONTAINS 'trimmed') "
                               "AND any(c IN {v}.captions WHERE c CONTAINS 'along a garden')"),
    "grey_sedan": dict(label="sedan", nouns=["sedan"], attrs=["grey", "small", "parking lane"],
                       pred="{v}.label = 'sedan' AND {v}.colour = 'grey' "
                            "AND any(c IN {v}.captions WHERE c CONTAINS 'small') "
                            "AND any(c IN {v}.captions WHERE c CONTAINS 'parking lane')"),
    "green_sedan": dict(label="sedan", nouns=["sedan"], attrs=["green"],
                        pred="{v}.label = 'sedan' AND {v}.colour = 'green'"),
    "red_scooter": dict(label="scooter", nouns=["scooter"], attrs=["red"],
                        pred="{v}.label = 'scooter' AND {v}.colour = 'red'"),
}


def P(name, v="n"):
    return D[name]["pred"].format(v=v)


def seg_obj_q(name):
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE %s RETURN id(n) AS id, id(s) AS seg" % P(name))


def kind_obj_q(name):
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE %s RETURN id(n) AS id, s.kind AS kind" % P(name))


def colour_in_seg_q(label, seg):
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE id(s) = %d AND n.label = '%s' "
            "RETURN id(n) AS id, n.colour AS colour, n.captions AS captions" % (seg, label))


def count_q(label):
    return "MATCH (n:Instance) WHERE n.label = '%s' RETURN count(n) AS count" % label


def count_in_seg_q(label, seg):
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE id(s) = %d AND n.label = '%s' "
            "RETURN count(n) AS count" % (seg, label))


def obj_pos(name, v):
    return "%s.centroid.x AS %sx, %s.centroid.z AS %sz" % (v, v, v, v)


# Noun vocabularies used by the label audits (captions must use them; nobody else may)
NOUNS = {
    "bench": (["bench"], ["bench inside"]),          # bus shelters/stops "with a bench inside"
    "hatchback": (["hatchback"], []),
    "letter box": (["letter box", "post box", "mailbox"], []),
    "hydrant": (["hydrant"], []),
    "trailer": (["trailer"], []),
    "speed limit sign": (["speed limit"], []),
    "traffic light": (["traffic light", "traffic signal"], []),
    "minibus": (["minibus"], []),
    "rubbish bin": (["rubbish bin", "litter bin", "trash can", " bin "], []),
}


def A_label(label, seg=None):
    nouns, exc = NOUNS[label]
    return lambda truth, info: audit_label(label, nouns, exc, seg)


def A_unique(name, seg=None):
    d = D[name]
    return lambda truth, info: audit_unique(info.get("obj", info.get("ref")), d["label"], d["nouns"], d["attrs"], seg)


def A_nearest(label, extra=None):
    # nearest answer must be an object of that label whose captions agree with it
    def f(truth, info):
        audit_label(label, *NOUNS[label])
        if extra:
            extra(truth, info)
    return f


def A_count_near(label, ref_name=None):
    def f(truth, info):
        audit_label(label, *NOUNS[label])
        if ref_name:
            A_unique(ref_name)(truth, info)
    return f


def A_colour_in_seg(label, seg):
    nouns, exc = NOUNS[label]

    def f(truth, info):
        audit_label(label, nouns, exc, seg)      # exactly one such object in the segment,
        audit_unique(info["obj"], label, nouns, (), seg)  # and nothing else there is called that
    return f


def A_distance(*names):
    def f(truth, info):
        for nm, key in names:
            d = D[nm]
            audit_unique(info[key], d["label"], d["nouns"], d["attrs"])
    return f


SEGS_ALL = "MATCH (s:Segment) RETURN count(s) AS count"


def segs_kind(k):
    return "MATCH (s:Segment) WHERE s.kind = '%s' RETURN count(s) AS count" % k


SPEC = [
    # ------------------------------------------------------------------ count
    ("count", "A", "Quick one before I send the cleaning bots out: how many benches are there across the whole map?",
     count_q("bench"), A_label("bench")),
    ("count", "A", "We're auditing parked cars by body style. How many hatchbacks does the map have in total?",
     count_q("hatchback"), A_label("hatchback")),
    ("count", "B", "How many post boxes are dotted about the whole area, all told?",
     count_q("letter box"), A_label("letter box")),
    ("count", "B", "I'm rather curious - how many fire hydrants are there in the entire neighbourhood?",
     count_q("hydrant"), A_label("hydrant")),
    ("count", "C", "Determine the total number of trailers recorded in the map.",
     count_q("trailer"), A_label("trailer")),
    ("count", "C", "State the number of speed limit signs present across the entire mapped area.",
     count_q("speed limit sign"), A_label("speed limit sign")),
    # ------------------------------------------------------------------ count_within
    ("count_within", "A", "How many hatchbacks are parked in segment #2411?",
     count_in_seg_q("hatchback", 2411), A_label("hatchback", 2411)),
    ("count_within", "A", "Unit 7 is inspecting seg 2406 - how many traffic lights are in that segment?",
     count_in_seg_q("traffic light", 2406), A_label("traffic light", 2406)),
    ("count_within", "B", "How many benches are there along segment 2414? I could do with a sit-down.",
     count_in_seg_q("bench", 2414), A_label("bench", 2414)),
    ("count_within", "B", "How many fire hydrants are there in segment number 2415?",
     count_in_seg_q("hydrant", 2415), A_label("hydrant", 2415)),
    ("count_within", "C", "Given segment 2416, determine the number of letter boxes (post boxes) located within it.",
     count_in_seg_q("letter box", 2416), A_label("letter box", 2416)),
    ("count_within", "C", "State how many speed limit signs lie within segment 2413.",
     count_in_seg_q("speed limit sign", 2413), A_label("speed limit sign", 2413)),
    # ------------------------------------------------------------------ count_segments
    ("count_segments", "A", "How many road segments does the map have altogether?", SEGS_ALL, None),
    ("count_segments", "A", "For the routing config, how many of the segments are four-way intersections?",
     segs_kind("intersection"), None),
    ("count_segments", "B", "How many T-junctions are there on the map?", segs_kind("t_intersection"), None),
    ("count_segments", "B", "How many bends are there - the L-shaped corners where the road turns?",
     segs_kind("l_intersection"), None),
    ("count_segments", "C", "Determine the number of segments classified as straight road sections.",
     segs_kind("straight_roadway"), None),
    ("count_segments", "C", "State the number of segments that are junctions of any type, i.e. every segment that is not a straight road section.",
     "MATCH (s:Segment) WHERE s.kind <> 'straight_roadway' RETURN count(s) AS count", None),
    # ------------------------------------------------------------------ count_near
    ("count_near", "A", "A bot is parked where the drive started. How many benches are within 50 m of that spot?",
     frame_near("start", "bench", 50.0), A_count_near("bench")),
    ("count_near", "A", "How many trailers are there within 20 metres of the blue scooter?",
     obj_near(P("blue_scooter", "a"), "trailer", 20.0), A_count_near("trailer", "blue_scooter")),
    ("count_near", "B", "How many hatchbacks are parked within 25 metres of where the drive finished?",
     frame_near("end", "hatchback", 25.0), A_count_near("hatchback")),
    ("count_near", "B", "I've got the children at the green climbing frame - how many post boxes are there within 25 metres of it?",
     obj_near(P("climbing_frame", "a"), "letter box", 25.0), A_count_near("letter box", "climbing_frame")),
    ("count_near", "C", "Determine the number of fire hydrants located within 40 m of the centroid of segment 2415.",
     seg_near(2415, "hydrant", 40.0), A_count_near("hydrant")),
    ("count_near", "C", "Given the crossroads segment 2404, state how many speed limit signs lie within 50 m of its centre.",
     seg_near(2404, "speed limit sign", 50.0), A_count_near("speed limit sign")),
    # ------------------------------------------------------------------ nearest
    ("nearest", "A", "Which fire hydrant is closest to the end of the drive?",
     frame_near("end", "hydrant"), A_nearest("hydrant")),
    ("nearest", "A", "The red delivery truck needs a tow. Which hatchback is parked nearest to it?",
     obj_near(P("red_truck", "a"), "hatchback"), A_nearest("hatchback", A_unique("red_truck"))),
    ("nearest", "B", "Which post box is nearest to where the drive began? I've a postcard to send.",
     frame_near("start", "letter box"), A_nearest("letter box")),
    ("nearest", "B", "Which bench is closest to the green climbing frame, so I can keep an eye on the little ones?",
     obj_near(P("climbing_frame", "a"), "bench"), A_nearest("bench", A_unique("climbing_frame"))),
    ("nearest", "C", "Identify the trailer located nearest to the centre of segment 2407.",
     seg_near(2407, "trailer"), A_nearest("trailer")),
    ("nearest", "C", "Identify the minibus situated nearest to the beige camper van.",
     obj_near(P("beige_camper", "a"), "minibus"), A_nearest("minibus", A_unique("beige_camper"))),
    # ------------------------------------------------------------------ distance
    ("distance", "A", "How far apart, in a straight line, are the start and the end of the drive?",
     "MATCH (f:Frame) WITH min(f.index) AS lo, max(f.index) AS hi MATCH (p:Frame), (q:Frame) "
     "WHERE p.index = lo AND q.index = hi RETURN p.world_from_velo[3] AS ax, p.world_from_velo[11] AS az, "
     "q.world_from_velo[3] AS bx, q.world_from_velo[11] AS bz", None),
    ("distance", "A", "What's the straight-line distance between the climbing frame and the red delivery truck?",
     "MATCH (a:Instance), (b:Instance) WHERE %s AND %s RETURN id(a) AS a, id(b) AS b, %s, %s"
     % (P("climbing_frame", "a"), P("red_truck", "b"), obj_pos("climbing_frame", "a"), obj_pos("red_truck", "b")),
     A_distance(("climbing_frame", "a"), ("red_truck", "b"))),
    ("distance", "B", "Roughly how far is the silver fire hydrant from where the drive set off, as the crow flies?",
     "MATCH (f:Frame) WITH min(f.index) AS m MATCH (g:Frame), (a:Instance) WHERE g.index = m AND %s "
     "RETURN id(a) AS a, a.centroid.x AS ax, a.centroid.z AS az, g.world_from_velo[3] AS bx, g.world_from_velo[11] AS bz"
     % P("silver_hydrant", "a"), A_distance(("silver_hydrant", "a"))),
    ("distance", "B", "As the crow flies, how far is it from where the drive ended to the middle of segment 2409?",
     "MATCH (f:Frame) WITH max(f.index) AS m MATCH (g:Frame), (s:Segment) WHERE g.index = m AND id(s) = 2409 "
     "RETURN g.world_from_velo[3] AS ax, g.world_from_velo[11] AS az, s.centroid.x AS bx, s.centroid.z AS bz", None),
    ("distance", "C", "Compute the straight-line ground distance between the centroids of segments 2403 and 2406.",
     "MATCH (s:Segment), (t:Segment) WHERE id(s) = 2403 AND id(t) = 2406 "
     "RETURN s.centroid.x AS ax, s.centroid.z AS az, t.centroid.x AS bx, t.centroid.z AS bz", None),
    ("distance", "C", "Determine the ground distance from the black hatchback with dusty windows to the centroid of segment 2417.",
     "MATCH (a:Instance), (s:Segment) WHERE %s AND id(s) = 2417 "
     "RETURN id(a) AS a, a.centroid.x AS ax, a.centroid.z AS az, s.centroid.x AS bx, s.centroid.z AS bz"
     % P("black_hatch", "a"), A_distance(("black_hatch", "a"))),
    # ------------------------------------------------------------------ route_length
    ("route_length", "A", "What's the route length along the lane graph from lane node 2425 to lane node 2429?",
     ROUTE % (2425, 2429), None),
    ("route_length", "A", "Say a bot drives the lane network from node 2433 to node 2434 - how long is the shortest route?",
     ROUTE % (2433, 2434), None),
    ("route_length", "B", "How far would I have to travel by road, following the lanes, from lane node 2426 to lane node 2428?",
     ROUTE % (2426, 2428), None),
    ("route_length", "B", "Keeping to the lanes, how far is it from lane node #2431 over to lane node #2424?",
     ROUTE % (2431, 2424), None),
    ("route_length", "C", "Determine the shortest route length over the lane graph between lane nodes 2432 and 2425.",
     ROUTE % (2432, 2425), None),
    ("route_length", "C", "Given lane nodes 2430 and 2434, compute the length of the shortest lane-graph route between them.",
     ROUTE % (2430, 2434), None),
    # ------------------------------------------------------------------ segment
    ("segment", "A", "Which segment is the black hatchback with the dusty windows in?", seg_obj_q("black_hatch"), A_unique("black_hatch")),
    ("segment", "A", "Got a ticket about the red delivery truck - which segment is it parked in?",
     seg_obj_q("red_truck"), A_unique("red_truck")),
    ("segment", "B", "Whereabouts is the silver fire hydrant - which segment would I find it in?",
     seg_obj_q("silver_hydrant"), A_unique("silver_hydrant")),
    ("segment", "B", "Which segment is the beige camper van parked up in?", seg_obj_q("beige_camper"), A_unique("beige_camper")),
    ("segment", "C", "State the segment that contains the green climbing frame.", seg_obj_q("climbing_frame"), A_unique("climbing_frame")),
    ("segment", "C", "Identify the segment in which the blue scooter is located.", seg_obj_q("blue_scooter"), A_unique("blue_scooter")),
    # ------------------------------------------------------------------ segment_kind
    ("segment_kind", "A", "What kind of road is the red scooter on?", kind_obj_q("red_scooter"), A_unique("red_scooter")),
    ("segment_kind", "A", "There's a trimmed hedge along a garden somewhere - what type of road segment is it in?",
     kind_obj_q("trimmed_hedge"), A_unique("trimmed_hedge")),
    ("segment_kind", "B", "What sort of road is the red cast-iron fire hydrant on the sidewalk beside - a straight bit, a bend or some kind of junction?",
     kind_obj_q("castiron_hydrant"), A_unique("castiron_hydrant")),
    ("segment_kind", "B", "What kind of road is the green saloon (sedan) parked on?", kind_obj_q("green_sedan"), A_unique("green_sedan")),
    ("segment_kind", "C", "State the road type of the segment containing the red-and-white speed limit sign that faces the traffic.",
     kind_obj_q("rw_sign"), A_unique("rw_sign")),
    ("segment_kind", "C", "Determine the kind of road segment on which the small grey sedan parked in the parking lane is located.",
     kind_obj_q("grey_sedan"), A_unique("grey_sedan")),
    # ------------------------------------------------------------------ colour
    ("colour", "A", "What colour is the hatchback in segment 2410?", colour_in_seg_q("hatchback", 2410),
     A_colour_in_seg("hatchback", 2410)),
    ("colour", "A", "Camera check on seg 2412: what colour is the traffic light there?", colour_in_seg_q("traffic light", 2412),
     A_colour_in_seg("traffic light", 2412)),
    ("colour", "B", "What colour is the post box along segment 2415?", colour_in_seg_q("letter box", 2415),
     A_colour_in_seg("letter box", 2415)),
    ("colour", "B", "What colour is the minibus parked in segment 2418?", colour_in_seg_q("minibus", 2418),
     A_colour_in_seg("minibus", 2418)),
    ("colour", "C", "State the colour of the rubbish bin located in segment 2416.", colour_in_seg_q("rubbish bin", 2416),
     A_colour_in_seg("rubbish bin", 2416)),
    ("colour", "C", "Given segment 2412, state the colour of the fire hydrant within it.", colour_in_seg_q("hydrant", 2412),
     A_colour_in_seg("hydrant", 2412)),
]


def write():
    with open(QFILE, "w") as f:
        for kind, voice, text, cy, _ in SPEC:
            truth, info = derive(kind, q(cy))
            f.write(json.dumps({"kind": kind, "question": text, "truth": truth, "cypher": cy}) + "\n")
    print("wrote", QFILE, len(SPEC), "questions")


def verify():
    lines = [json.loads(l) for l in open(QFILE)]
    assert len(lines) == len(SPEC) == 60, (len(lines), len(SPEC))
    by_kind, by_voice, bad = {}, {}, 0
    for i, (rec, spec) in enumerate(zip(lines, SPEC)):
        kind, voice, text, cy, audit = spec
        assert rec["kind"] == kind and rec["question"] == text, "line %d differs from SPEC" % (i + 1)
        try:
            truth, info = derive(rec["kind"], q(rec["cypher"]))
            if audit:
                audit(truth, info)
            ok = truth == rec["truth"]
        except AssertionError as e:
            ok, truth = False, "ASSERT: %s" % e
        by_kind[kind] = by_kind.get(kind, 0) + 1
        by_voice[voice] = by_voice.get(voice, 0) + 1
        extra = ""
        if kind == "nearest" and ok:
            extra = "  (d=%.2f, margin=%.2f)" % (info["nearest_d"], info["margin"])
        print("%2d %-14s %s %-6s %s%s" % (i + 1, kind, voice, "OK" if ok else "FAIL", json.dumps(rec["truth"]), extra))
        if not ok:
            bad += 1
            print("     re-derived:", truth)
    print("per kind:", by_kind)
    print("per voice:", by_voice)
    print("ALL %d TRUTHS REPRODUCED" % len(lines) if not bad else "%d FAILURES" % bad)
    return bad == 0


if __name__ == "__main__":
    if "--write" in sys.argv:
        write()
    sys.exit(0 if verify() else 1)
