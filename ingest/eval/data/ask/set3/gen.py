#!/usr/bin/env python3
"""Build / verify the indep3 held-out question set.

    python3 gen.py --write   # (re)build questions.jsonl from SPECS below
    python3 gen.py           # verify: re-run every stored cypher in questions.jsonl,
                             # re-derive the truth, compare, and run the extra
                             # uniqueness / margin checks.

Only read-only Cypher queries against /work/main/out/city.og are issued, through
/tmp/opengraph_old.  Geometry conventions (from the brief):
  * ground distance = sqrt(dx^2 + dz^2) between centroids (y ignored)
  * drive start / end = Frame with lowest / highest index, x = world_from_velo[3],
    z = world_from_velo[11]
  * route length = Dijkstra over LANE edges, undirected, weight length_m
  * distances rounded (in Python) to 0.01 m

Each stored cypher follows an output convention that depends on the kind:
  count, count_within, count_segments : one row, column `count`
  count_near   : one row per object of the kind: `id`, `d`, `radius`
  nearest      : one row per object of the kind: `id`, `d` (+ optional `anchor`)
  distance     : exactly one row with column `d`
  route_length : the LANE edge list `a`, `b`, `w` plus constant columns `src`, `dst`
  segment      : exactly one row `id`, `segment`
  segment_kind : exactly one row `id`, `kind`
  colour       : exactly one row `id`, `colour`
"""
import heapq
import json
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


def q(cypher):
    r = subprocess.run([BIN, "query", "--db", DB, "--read-only", "--json", cypher],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError("query failed: %s\n%s" % (cypher, r.stderr))
    out = r.stdout
    return json.loads(out[: out.rfind("]") + 1])


# --------------------------------------------------------------------------
# Cypher building blocks
# --------------------------------------------------------------------------
START = "MATCH (f:Frame) WITH f ORDER BY f.index ASC LIMIT 1 "
END = "MATCH (f:Frame) WITH f ORDER BY f.index DESC LIMIT 1 "
FX, FZ = "f.world_from_velo[3]", "f.world_from_velo[11]"


def gd(ax, az, bx, bz):
    return "sqrt((%s - %s)^2 + (%s - %s)^2)" % (ax, bx, az, bz)


def cen(v):
    return "%s.centroid.x" % v, "%s.centroid.z" % v


def caps_any(kws, var="n"):
    """caption or any caption contains any of the keywords (lower-cased)."""
    parts = []
    for k in kws:
        parts.append("toLower(%s.caption) CONTAINS '%s'" % (var, k))
        parts.append("any(c IN %s.captions WHERE toLower(c) CONTAINS '%s')" % (var, k))
    return "(" + " OR ".join(parts) + ")"


def caps_all_words(words, var="n"):
    """some single caption contains all the words."""
    cond = " AND ".join("toLower(c) CONTAINS '%s'" % w for w in words)
    return "any(c IN %s.captions + [%s.caption] WHERE %s)" % (var, var, cond)


def other_label_check(label, kws, extra=""):
    """instances NOT of `label` whose captions mention the kind -> must be empty."""
    return ("MATCH (n:Instance) WHERE n.label IS NOT NULL AND n.label <> '%s' AND %s %s "
            "RETURN id(n) AS id" % (label, caps_any(kws), extra), [])


# keyword sets per counted label (used for caption/label consistency checks)
KW = {
    "hydrant": ["hydrant"],
    "rubbish bin": ["trash", "rubbish bin", "litter bin", "garbage", "waste bin"],
    "letter box": ["mailbox", "letter box", "letterbox", "post box", "postbox"],
    "traffic light": ["traffic light", "traffic signal"],
    "trailer": ["trailer"],
    "hatchback": ["hatchback"],
}
BENCH_CHECK = ("MATCH (n:Instance) WHERE n.label IS NOT NULL AND n.label <> 'bench' AND "
               "any(c IN n.captions + [n.caption] WHERE toLower(c) CONTAINS 'bench' AND NOT "
               "toLower(c) CONTAINS 'bench inside') RETURN id(n) AS id", [])


def kind_check(label):
    if label == "bench":
        return BENCH_CHECK
    return other_label_check(label, KW[label])


def unique_check(where, expect_id):
    """all instances matching a broad description -> exactly [expect_id]."""
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE %s RETURN id(n) AS id" % where,
            [expect_id])


def colour_agree_check(where, colour):
    """the described object: every caption mentions the stored colour."""
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE %s "
            "AND all(c IN n.captions + [n.caption] WHERE toLower(c) CONTAINS '%s') "
            "RETURN id(n) AS id" % (where, colour), "nonempty")


def count_label(label, seg=None):
    if seg is None:
        return "MATCH (n:Instance) WHERE n.label = '%s' RETURN count(n) AS count" % label
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE id(s) = %d AND n.label = '%s' "
            "RETURN count(n) AS count" % (seg, label))


def near_from_frame(which, label, radius):
    pre = START if which == "start" else END
    return (pre + "MATCH (n:Instance) WHERE n.label = '%s' RETURN id(n) AS id, %s AS d, %s AS radius "
            "ORDER BY d" % (label, gd(*cen("n"), FX, FZ), float(radius)))


def near_from_seg(seg, label, radius):
    return ("MATCH (s:Segment) WHERE id(s) = %d MATCH (n:Instance) WHERE n.label = '%s' "
            "RETURN id(n) AS id, %s AS d, %s AS radius ORDER BY d"
            % (seg, label, gd(*cen("n"), *cen("s")), float(radius)))


def near_from_obj(anchor_where, label, radius):
    return ("MATCH (m:Instance)-[:IN_SEGMENT]->(ms:Segment) WHERE %s "
            "MATCH (n:Instance) WHERE n.label = '%s' AND id(n) <> id(m) "
            "RETURN id(m) AS anchor, id(n) AS id, %s AS d, %s AS radius ORDER BY d"
            % (anchor_where, label, gd(*cen("n"), *cen("m")), float(radius)))


def nearest_from_frame(which, label):
    pre = START if which == "start" else END
    return (pre + "MATCH (n:Instance) WHERE n.label = '%s' RETURN id(n) AS id, %s AS d ORDER BY d"
            % (label, gd(*cen("n"), FX, FZ)))


def nearest_from_seg(seg, label):
    return ("MATCH (s:Segment) WHERE id(s) = %d MATCH (n:Instance) WHERE n.label = '%s' "
            "RETURN id(n) AS id, %s AS d ORDER BY d" % (seg, label, gd(*cen("n"), *cen("s"))))


def nearest_from_obj(anchor_where, label):
    return ("MATCH (m:Instance)-[:IN_SEGMENT]->(ms:Segment) WHERE %s "
            "MATCH (n:Instance) WHERE n.label = '%s' AND id(n) <> id(m) "
            "RETURN id(m) AS anchor, id(n) AS id, %s AS d ORDER BY d"
            % (anchor_where, label, gd(*cen("n"), *cen("m"))))


def lane_edges(src, dst):
    return ("MATCH (a:LaneNode)-[r:LANE]->(b:LaneNode) RETURN id(a) AS a, id(b) AS b, "
            "r.length_m AS w, %d AS src, %d AS dst" % (src, dst))


def lane_edges_seg_dst(src, dst_seg):
    return ("MATCH (x:LaneNode)-[:IN_SEGMENT]->(t:Segment) WHERE id(t) = %d WITH id(x) AS dst "
            "MATCH (a:LaneNode)-[r:LANE]->(b:LaneNode) RETURN id(a) AS a, id(b) AS b, "
            "r.length_m AS w, %d AS src, dst" % (dst_seg, src))


def seg_of(where):
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE %s RETURN id(n) AS id, id(s) AS segment"
            % where)


def kind_of(where):
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE %s RETURN id(n) AS id, s.kind AS kind"
            % where)


def colour_of(where):
    return ("MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE %s RETURN id(n) AS id, n.colour AS colour"
            % where)


# descriptions (WHERE clauses over n / s) of described objects
D_TRUCK = "n.label = 'delivery truck' AND n.colour = 'red'"
D_BILLBOARD = "n.label = 'billboard' AND n.colour = 'white'"
D_CLIMB = "n.label = 'climbing frame' AND n.colour = 'green'"
D_MINIBUS_2423 = "n.label = 'minibus' AND id(s) = 2423"
D_SCOOTER_SILVER = "n.label = 'scooter' AND n.colour = 'silver'"
D_CAMPER_BEIGE = "n.label = 'camper van' AND n.colour = 'beige'"
D_HYDRANT_SILVER = "n.label = 'hydrant' AND n.colour = 'silver'"
D_HATCH_DUSTY_YELLOW = "n.label = 'hatchback' AND n.colour = 'yellow' AND toLower(n.caption) CONTAINS 'dusty'"


def m_(where):  # same description for anchor variable m / ms
    return where.replace("n.", "m.").replace("id(s)", "id(ms)")


# broad uniqueness checks for those descriptions (by caption text, any label)
U_TRUCK = unique_check("(n.label = 'delivery truck' OR %s) AND (n.colour = 'red' OR %s)"
                       % (caps_any(["delivery truck"]), caps_all_words(["delivery truck", "red"])), 998)
U_BILLBOARD = unique_check("(n.label = 'billboard' OR %s)" % caps_any(["billboard"]), 897)
U_CLIMB = unique_check("(n.label = 'climbing frame' OR %s) AND (n.colour = 'green' OR %s)"
                       % (caps_any(["climbing frame"]), caps_all_words(["climbing frame", "green"])), 1108)
U_MINIBUS_2423 = unique_check("id(s) = 2423 AND (n.label = 'minibus' OR %s)" % caps_any(["minibus"]), 695)
U_SCOOTER_SILVER = unique_check("(n.label = 'scooter' OR %s) AND (n.colour = 'silver' OR %s)"
                                % (caps_any(["scooter"]), caps_all_words(["scooter", "silver"])), 2059)
U_CAMPER_BEIGE = unique_check("(n.label = 'camper van' OR %s) AND (n.colour = 'beige' OR %s)"
                              % (caps_any(["camper"]), caps_all_words(["camper", "beige"])), 2286)
U_HYDRANT_SILVER = unique_check("(n.label = 'hydrant' OR %s) AND (n.colour = 'silver' OR %s)"
                                % (caps_any(["hydrant"]), caps_all_words(["hydrant", "silver"])), 922)
U_HATCH_DUSTY_YELLOW = unique_check("(n.label = 'hatchback' OR %s) AND %s"
                                    % (caps_any(["hatchback"]), caps_all_words(["yellow", "dusty"])), 87)

# persona tags: V = voice-transcribed robot operator, L = non-native English
# learner, D = delivery dispatcher
SPECS = [
    # ------------------------------------------------------------------ count
    dict(p="V", kind="count",
         question="okay so uh how many fire hydrants are there on the whole map",
         cypher=count_label("hydrant"), checks=[kind_check("hydrant")]),
    dict(p="L", kind="count",
         question="How much trash cans the map is having in total?",
         cypher=count_label("rubbish bin"), checks=[kind_check("rubbish bin")]),
    dict(p="D", kind="count",
         question="Morning. We're planning a mail pickup round over the whole area you mapped, and "
                  "before I assign drivers I need one number: how many mailboxes are on the map altogether?",
         cypher=count_label("letter box"), checks=[kind_check("letter box")]),
    dict(p="V", kind="count",
         question="uh how many benches did we map like in total",
         cypher=count_label("bench"), checks=[kind_check("bench")]),
    dict(p="L", kind="count",
         question="In all the map, how many traffic light there is?",
         cypher=count_label("traffic light"), checks=[kind_check("traffic light")]),
    dict(p="D", kind="count",
         question="Quick one for the yard team. They keep asking me about parked trailers and I have "
                  "no idea. How many trailers are there on the map in total?",
         cypher=count_label("trailer"), checks=[kind_check("trailer")]),
    # ----------------------------------------------------------- count_within
    dict(p="V", kind="count_within",
         question="okay how many benches are in segment 2412",
         cypher=count_label("bench", 2412), checks=[kind_check("bench")]),
    dict(p="L", kind="count_within",
         question="How many litter bin is inside the seg 2421?",
         cypher=count_label("rubbish bin", 2421), checks=[kind_check("rubbish bin")]),
    dict(p="D", kind="count_within",
         question="I've got a driver waiting in segment #2415 for a colleague's car. All he remembers "
                  "is that it's a hatchback. How many hatchbacks are in that segment?",
         cypher=count_label("hatchback", 2415), checks=[kind_check("hatchback")]),
    dict(p="V", kind="count_within",
         question="um traffic lights in segment 2401 how many are there",
         cypher=count_label("traffic light", 2401), checks=[kind_check("traffic light")]),
    dict(p="L", kind="count_within",
         question="In the segment number 2416, how many post box are located?",
         cypher=count_label("letter box", 2416), checks=[kind_check("letter box")]),
    dict(p="D", kind="count_within",
         question="Fire safety inspection is booked for seg 2416 next week. The inspector asked me "
                  "how many hydrants that segment has. Can you tell me?",
         cypher=count_label("hydrant", 2416), checks=[kind_check("hydrant")]),
    # --------------------------------------------------------- count_segments
    dict(p="V", kind="count_segments",
         question="uh how many road segments are there on the map in total",
         cypher="MATCH (s:Segment) RETURN count(s) AS count", checks=[]),
    dict(p="L", kind="count_segments",
         question="How many four-way crossing the map have?",
         cypher="MATCH (s:Segment) WHERE s.kind = 'intersection' RETURN count(s) AS count", checks=[]),
    dict(p="D", kind="count_segments",
         question="We're redrawing the route cards for the new drivers. I need to know how many "
                  "T-intersections there are on the map.",
         cypher="MATCH (s:Segment) WHERE s.kind = 't_intersection' RETURN count(s) AS count", checks=[]),
    dict(p="V", kind="count_segments",
         question="okay so how many bends or corners does the map have",
         cypher="MATCH (s:Segment) WHERE s.kind = 'l_intersection' RETURN count(s) AS count", checks=[]),
    dict(p="L", kind="count_segments",
         question="How many segment of straight road is existing in the map?",
         cypher="MATCH (s:Segment) WHERE s.kind = 'straight_roadway' RETURN count(s) AS count", checks=[]),
    dict(p="D", kind="count_segments",
         question="The hydrant maintenance crew plans their week segment by segment. In how many "
                  "different segments is there at least one fire hydrant?",
         cypher="MATCH (n:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE n.label = 'hydrant' "
                "RETURN count(DISTINCT s) AS count",
         checks=[kind_check("hydrant")]),
    # ------------------------------------------------------------- count_near
    dict(p="D", kind="count_near",
         question="Driver just radioed in from the spot where the drive started, says there are "
                  "signals everywhere around him. How many traffic lights are within 20 metres of "
                  "the drive's starting point?",
         cypher=near_from_frame("start", "traffic light", 20), checks=[kind_check("traffic light")]),
    dict(p="V", kind="count_near",
         question="okay so um how many benches are within 50 metres of where the drive ended",
         cypher=near_from_frame("end", "bench", 50), checks=[kind_check("bench")]),
    dict(p="L", kind="count_near",
         question="Around the centre of segment 2421, inside 25 metre, how many rubbish bin you can find?",
         cypher=near_from_seg(2421, "rubbish bin", 25), checks=[kind_check("rubbish bin")]),
    dict(p="D", kind="count_near",
         question="Customer is waiting next to the minibus in segment 2423. She says her hatchback "
                  "is parked close to it. How many hatchbacks are within 15 m of that minibus?",
         cypher=near_from_obj(m_(D_MINIBUS_2423), "hatchback", 15),
         checks=[kind_check("hatchback"), U_MINIBUS_2423]),
    dict(p="V", kind="count_near",
         question="uh how many mailboxes are within 25 metres of the green climbing frame",
         cypher=near_from_obj(m_(D_CLIMB), "letter box", 25),
         checks=[kind_check("letter box"), U_CLIMB]),
    dict(p="L", kind="count_near",
         question="How many trash bin there are within 20 metres from the red delivery truck?",
         cypher=near_from_obj(m_(D_TRUCK), "rubbish bin", 20),
         checks=[kind_check("rubbish bin"), U_TRUCK]),
    # ---------------------------------------------------------------- nearest
    dict(p="V", kind="nearest",
         question="uh which fire hydrant is closest to where the drive ended",
         cypher=nearest_from_frame("end", "hydrant"), checks=[kind_check("hydrant")]),
    dict(p="L", kind="nearest",
         question="Which trash can is the most near to the start point of the drive?",
         cypher=nearest_from_frame("start", "rubbish bin"), checks=[kind_check("rubbish bin")]),
    dict(p="D", kind="nearest",
         question="I'm sending a worn-out courier to the middle of segment 2406 and he needs to sit "
                  "down for a bit. Which bench is nearest to the centre of that segment?",
         cypher=nearest_from_seg(2406, "bench"), checks=[kind_check("bench")]),
    dict(p="V", kind="nearest",
         question="okay so which hatchback is nearest to the minibus in segment 2423",
         cypher=nearest_from_obj(m_(D_MINIBUS_2423), "hatchback"),
         checks=[kind_check("hatchback"), U_MINIBUS_2423]),
    dict(p="L", kind="nearest",
         question="The white billboard, which bench is the most close to it?",
         cypher=nearest_from_obj(m_(D_BILLBOARD), "bench"),
         checks=[kind_check("bench"), U_BILLBOARD]),
    dict(p="D", kind="nearest",
         question="A letter needs posting near the centre of seg #2410. Which mailbox is closest to "
                  "the centre of that segment? Just give me the object id.",
         cypher=nearest_from_seg(2410, "letter box"), checks=[kind_check("letter box")]),
    # --------------------------------------------------------------- distance
    dict(p="D", kind="distance",
         question="For the fleet log: the drive started at one spot and finished at another. How far "
                  "apart are those two points in a straight line over the ground?",
         cypher="MATCH (f:Frame) WITH f ORDER BY f.index ASC LIMIT 1 MATCH (g:Frame) WITH f, g "
                "ORDER BY g.index DESC LIMIT 1 RETURN id(f) AS start_frame, id(g) AS end_frame, "
                + gd(FX, FZ, "g.world_from_velo[3]", "g.world_from_velo[11]") + " AS d",
         checks=[]),
    dict(p="V", kind="distance",
         question="uh whats the straight line distance between the red delivery truck and the white billboard",
         cypher="MATCH (n:Instance), (m:Instance) WHERE %s AND %s RETURN id(n) AS a, id(m) AS b, %s AS d"
                % (D_TRUCK, D_BILLBOARD.replace("n.", "m."), gd(*cen("n"), *cen("m"))),
         checks=[U_TRUCK, U_BILLBOARD]),
    dict(p="L", kind="distance",
         question="What is the distance between centre of segment 2403 and centre of segment 2409, "
                  "in straight line?",
         cypher="MATCH (s:Segment), (t:Segment) WHERE id(s) = 2403 AND id(t) = 2409 RETURN %s AS d"
                % gd(*cen("s"), *cen("t")),
         checks=[]),
    dict(p="D", kind="distance",
         question="I'm standing where the drive started. Segment 2406 is where I need to be. As the "
                  "crow flies, how far is it to the centre of that one?",
         cypher=START + "MATCH (s:Segment) WHERE id(s) = 2406 RETURN %s AS d" % gd(*cen("s"), FX, FZ),
         checks=[]),
    dict(p="V", kind="distance",
         question="okay so distance from object 86 to object 1481 straight line please",
         cypher="MATCH (n:Instance), (m:Instance) WHERE id(n) = 86 AND id(m) = 1481 RETURN %s AS d"
                % gd(*cen("n"), *cen("m")),
         checks=[]),
    dict(p="L", kind="distance",
         question="From the end of the drive until the beige camper van, how many metres it is in straight line?",
         cypher=END + "MATCH (n:Instance) WHERE %s RETURN id(n) AS id, %s AS d"
                % (D_CAMPER_BEIGE, gd(*cen("n"), FX, FZ)),
         checks=[U_CAMPER_BEIGE]),
    # ----------------------------------------------------------- route_length
    dict(p="V", kind="route_length",
         question="okay so uh if i drive along the lanes from lane node 2425 to lane node 2433 how "
                  "long is the shortest route",
         cypher=lane_edges(2425, 2433), checks=[]),
    dict(p="L", kind="route_length",
         question="How long is the shortest way on the lane graph from node 2434 until node 2432?",
         cypher=lane_edges(2434, 2432), checks=[]),
    dict(p="D", kind="route_length",
         question="Van is sitting at lane node 2433 right now. Next drop is at the lane node that "
                  "lies in segment 2408. What's the shortest driving distance along the lane network "
                  "between the two?",
         cypher=lane_edges_seg_dst(2433, 2408), checks=[]),
    dict(p="V", kind="route_length",
         question="uh shortest lane route length between lane node 2428 and lane node 2432",
         cypher=lane_edges(2428, 2432), checks=[]),
    dict(p="L", kind="route_length",
         question="Driving on the lanes, what is the shortest distance from lane node 2426 to the lane node 2429?",
         cypher=lane_edges(2426, 2429), checks=[]),
    dict(p="D", kind="route_length",
         question="Two of our vans: one at lane node 2425, the other at lane node 2431. If the first "
                  "drives over to the second along the lanes, what's the shortest route length?",
         cypher=lane_edges(2425, 2431), checks=[]),
    # ---------------------------------------------------------------- segment
    dict(p="V", kind="segment",
         question="which segment is the red delivery truck in",
         cypher=seg_of(D_TRUCK), checks=[U_TRUCK]),
    dict(p="L", kind="segment",
         question="The silver scooter, in which segment it is standing?",
         cypher=seg_of(D_SCOOTER_SILVER), checks=[U_SCOOTER_SILVER]),
    dict(p="D", kind="segment",
         question="There's a trailer we've been keeping an eye on, object 86. Which segment is that one in?",
         cypher=seg_of("id(n) = 86"), checks=[]),
    dict(p="V", kind="segment",
         question="uh what segment is the beige camper van parked in",
         cypher=seg_of(D_CAMPER_BEIGE), checks=[U_CAMPER_BEIGE]),
    dict(p="L", kind="segment",
         question="In what segment is located the silver fire hydrant?",
         cypher=seg_of(D_HYDRANT_SILVER), checks=[U_HYDRANT_SILVER]),
    dict(p="D", kind="segment",
         question="Kids' party delivery today. The drop point is at the green climbing frame. "
                  "Which segment is that in?",
         cypher=seg_of(D_CLIMB), checks=[U_CLIMB]),
    # ----------------------------------------------------------- segment_kind
    dict(p="V", kind="segment_kind",
         question="okay so object 1481 what kind of road is it on like a crossroads or a bend or what",
         cypher=kind_of("id(n) = 1481"), checks=[]),
    dict(p="L", kind="segment_kind",
         question="The object 1317, on which kind of road it stands? Four-way, T-intersection, corner "
                  "or straight stretch?",
         cypher=kind_of("id(n) = 1317"), checks=[]),
    dict(p="D", kind="segment_kind",
         question="We've got traffic light 623 flagged as faulty. What type of road does that one sit "
                  "on: a four-way crossroads, a T-junction, a bend, or a straight stretch?",
         cypher=kind_of("id(n) = 623"), checks=[]),
    dict(p="V", kind="segment_kind",
         question="uh the yellow hatchback with the dusty windows what kind of road is that on",
         cypher=kind_of(D_HATCH_DUSTY_YELLOW), checks=[U_HATCH_DUSTY_YELLOW]),
    dict(p="L", kind="segment_kind",
         question="What kind of road is the object 920 on?",
         cypher=kind_of("id(n) = 920"), checks=[]),
    dict(p="D", kind="segment_kind",
         question="Courier says he's standing right next to the red delivery truck. I want to know "
                  "what sort of road he's on. Junction, bend, or just a straight bit?",
         cypher=kind_of(D_TRUCK), checks=[U_TRUCK]),
    # ----------------------------------------------------------------- colour
    dict(p="V", kind="colour",
         question="uh what colour is the scooter in segment 2410",
         cypher=colour_of("n.label = 'scooter' AND id(s) = 2410"),
         checks=[unique_check("id(s) = 2410 AND (n.label = 'scooter' OR %s)" % caps_any(["scooter"]), 64),
                 colour_agree_check("id(n) = 64", "blue")]),
    dict(p="L", kind="colour",
         question="Which colour has the minibus in the segment 2418?",
         cypher=colour_of("n.label = 'minibus' AND id(s) = 2418"),
         checks=[unique_check("id(s) = 2418 AND (n.label = 'minibus' OR %s)" % caps_any(["minibus"]), 1964),
                 colour_agree_check("id(n) = 1964", "beige")]),
    dict(p="D", kind="colour",
         question="Hydrant check in segment 2412. There should be just the one hydrant in there. "
                  "What colour is it?",
         cypher=colour_of("n.label = 'hydrant' AND id(s) = 2412"),
         checks=[unique_check("id(s) = 2412 AND (n.label = 'hydrant' OR %s)" % caps_any(["hydrant"]), 1557),
                 colour_agree_check("id(n) = 1557", "red")]),
    dict(p="V", kind="colour",
         question="okay so the letter box in segment 2422 what colour is it",
         cypher=colour_of("n.label = 'letter box' AND id(s) = 2422"),
         checks=[unique_check("id(s) = 2422 AND (n.label = 'letter box' OR %s)" % caps_any(KW["letter box"]), 2133),
                 colour_agree_check("id(n) = 2133", "yellow")]),
    dict(p="L", kind="colour",
         question="The bench in segment 2413, what colour it has?",
         cypher=colour_of("n.label = 'bench' AND id(s) = 2413"),
         checks=[unique_check("id(s) = 2413 AND (n.label = 'bench' OR any(c IN n.captions + [n.caption] "
                              "WHERE toLower(c) CONTAINS 'bench' AND NOT toLower(c) CONTAINS 'bench inside'))", 411),
                 colour_agree_check("id(n) = 411", "brown")]),
    dict(p="D", kind="colour",
         question="Someone dropped a bag into the litter bin in seg 2416 by mistake. I need to tell the "
                  "cleaner which bin to look for. What colour is that one?",
         cypher=colour_of("n.label = 'rubbish bin' AND id(s) = 2416"),
         checks=[unique_check("id(s) = 2416 AND (n.label = 'rubbish bin' OR %s)" % caps_any(KW["rubbish bin"]), 1169),
                 colour_agree_check("id(n) = 1169", "black")]),
]


# --------------------------------------------------------------------------
# derivation
# --------------------------------------------------------------------------
def one(rows):
    assert len(rows) == 1, "expected exactly one row, got %d: %s" % (len(rows), rows[:5])
    return rows[0]


def dijkstra(rows):
    pairs = {(r["src"], r["dst"]) for r in rows}
    assert len(pairs) == 1, pairs
    src, dst = pairs.pop()
    g = {}
    for r in rows:
        g.setdefault(r["a"], []).append((r["b"], r["w"]))
        g.setdefault(r["b"], []).append((r["a"], r["w"]))
    dist = {src: 0.0}
    pq = [(0.0, src)]
    while pq:
        d, u = heapq.heappop(pq)
        if d > dist.get(u, float("inf")):
            continue
        if u == dst:
            return d
        for v, w in g.get(u, []):
            nd = d + w
            if nd < dist.get(v, float("inf")):
                dist[v] = nd
                heapq.heappush(pq, (nd, v))
    raise AssertionError("no route %s -> %s" % (src, dst))


def derive(kind, rows):
    """returns (truth, note) and asserts the margin / uniqueness rules."""
    if kind in ("count", "count_within", "count_segments"):
        return {"count": int(one(rows)["count"])}, ""
    if kind == "count_near":
        assert rows, "no objects of the kind"
        if "anchor" in rows[0]:
            assert len({r["anchor"] for r in rows}) == 1, "anchor not unique"
        radius = rows[0]["radius"]
        margin = min(abs(r["d"] - radius) for r in rows)
        assert margin >= 1.0, "object within 1 m of the radius boundary (%.3f)" % margin
        c = sum(1 for r in rows if r["d"] < radius)
        return {"count": c}, "R=%g margin=%.2f" % (radius, margin)
    if kind == "nearest":
        if "anchor" in rows[0]:
            assert len({r["anchor"] for r in rows}) == 1, "anchor not unique"
        rs = sorted(rows, key=lambda r: r["d"])
        assert len(rs) >= 2
        gap = rs[1]["d"] - rs[0]["d"]
        assert gap >= 0.5, "second nearest too close (%.3f)" % gap
        return {"id": rs[0]["id"]}, "d=%.2f gap=%.2f" % (rs[0]["d"], gap)
    if kind == "distance":
        return {"metres": round(one(rows)["d"], 2)}, ""
    if kind == "route_length":
        return {"metres": round(dijkstra(rows), 2)}, ""
    if kind == "segment":
        return {"segment": one(rows)["segment"]}, "obj=%s" % rows[0]["id"]
    if kind == "segment_kind":
        return {"segment_kind": KIND_MAP[one(rows)["kind"]]}, "obj=%s" % rows[0]["id"]
    if kind == "colour":
        c = one(rows)["colour"]
        assert c, "colour is null"
        return {"colour": c}, "obj=%s" % rows[0]["id"]
    raise ValueError(kind)


def run_checks(spec):
    for cy, expect in spec["checks"]:
        ids = sorted(r["id"] for r in q(cy))
        if expect == "nonempty":
            assert ids, "check returned nothing: %s" % cy
        else:
            assert ids == sorted(expect), "check failed: got %s expected %s\n  %s" % (ids, expect, cy)


def main():
    write = "--write" in sys.argv
    if write:
        with open(OUT, "w") as fh:
            for s in SPECS:
                truth, note = derive(s["kind"], q(s["cypher"]))
                run_checks(s)
                fh.write(json.dumps({"kind": s["kind"], "question": s["question"],
                                     "truth": truth, "cypher": s["cypher"]}) + "\n")
        print("wrote %d questions to %s" % (len(SPECS), OUT))
    lines = [json.loads(l) for l in open(OUT)]
    assert len(lines) == len(SPECS), (len(lines), len(SPECS))
    bad = 0
    per_kind, per_persona = {}, {}
    for i, (line, spec) in enumerate(zip(lines, SPECS)):
        assert line["question"] == spec["question"] and line["kind"] == spec["kind"], i
        try:
            truth, note = derive(line["kind"], q(line["cypher"]))
            run_checks(spec)
            ok = truth == line["truth"]
        except AssertionError as e:
            ok, truth, note = False, None, "ASSERT: %s" % e
        bad += not ok
        per_kind[line["kind"]] = per_kind.get(line["kind"], 0) + 1
        per_persona[spec["p"]] = per_persona.get(spec["p"], 0) + 1
        print("%-3d %-4s %-14s %-34s %s %s" % (i + 1, "ok" if ok else "FAIL", line["kind"],
                                              json.dumps(line["truth"]), note, spec["p"]))
    print("per kind:", per_kind)
    print("per persona:", per_persona)
    print("ALL %d TRUTHS REPRODUCED" % len(lines) if not bad else "%d FAILURES" % bad)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
