#!/usr/bin/env python3
"""Held-out question set 11: spec, truth recomputation and audits.

Usage:
  python3 gen.py           # re-run every cypher, recompute truths, run audits, compare with questions.jsonl
  python3 gen.py --write   # same, then (re)write questions.jsonl from the spec (only if everything passes)

Environment:
  OPENGRAPH          the opengraph CLI (default /tmp/ask8/opengraph)
  OPENGRAPH_ASK_DB   the map store   (default /tmp/ask8/city.og; the default small city,
                     `opengraph sim --size small --seed 0` + `opengraph build`, commit e5afdf6;
                     the same map as sets 8, 9 and 10)

Every query is run with --read-only. Ground plane is (x, z); y is up.

This file holds only what is set 11's own (defaults, vocabulary, questions and its audits: reuse of
sets 7-10, coinciding reference points, a broad fence count, route pairs asked at most twice). The
helpers shared by sets 7-11 (cypher builders, running the queries, truth recomputation, the common
audits, the PASS/FAIL report) are in ../askgen.py.
"""
import os
import re
import sys
from collections import Counter

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))   # for ../askgen.py
from askgen import Q_ALL, Q_ALL_SEGMENTS, Q_LANES, add, distance, near, nearest, route, run, within  # noqa: E402
from askgen import q_colour, q_count, q_count_segments, q_segment, main as check  # noqa: E402
import askgen  # noqa: E402

OG_DEFAULT = "/tmp/ask8/opengraph"   # $OPENGRAPH
DB_DEFAULT = "/tmp/ask8/city.og"     # $OPENGRAPH_ASK_DB

# ---------------------------------------------------------------- vocabulary
# Labels that are counted / searched for, with a broad regex for how a caption (or label)
# names the kind (synonyms included). The audit requires every object of the label to have a
# caption matching it, and no object of any other label (or unlabelled) to match it.
# Set 10's list. utility pole passes this audit too (r"\bpoles?\b") but is NOT used: several
# objects labelled `lamp post` are captioned "post carrying cables", which a reader may count
# as utility poles.
KINDS = {
    "hydrant":          r"hydrant",
    "letter box":       r"post ?box|letter ?box|mail ?box|pillar box",
    "rubbish bin":      r"\bbins?\b|trash|rubbish|litter|garbage|dustbin|waste",
    "traffic light":    r"traffic (light|signal)|stop ?light|\bsignals?\b",
    "trailer":          r"trailer",
    "hatchback":        r"hatchback",
    "suv":              r"\bsuvs?\b|sport utility|4x4",
    "scooter":          r"scooter|moped",
    "speed limit sign": r"speed limit|speed sign",
    "camper van":       r"camper|motorhome|\bvan\b|\brv\b",
    "minibus":          r"mini-? ?bus|\bbus\b(?!\s*(stop|shelter))",
    "sedan":            r"sedan|saloon",
    "fence":            r"fence",
}
# For count_within, the count under a broader reading of the noun must equal the truth too
# (a reader may take a railing for a fence).
BROAD_COUNT = {"fence": r"fence|railing"}

# Nouns used in descriptions of single objects (broad readings: label or any caption).
# Set 10's, plus "bench" (which also takes in the bus stops captioned "with a bench inside").
NOUNS = {
    "car":              r"\bcars?\b|sedan|saloon|hatchback|\bsuvs?\b|sport utility|minibus",
    "hatchback":        r"hatchback",
    "suv":              r"\bsuvs?\b|sport utility|4x4",
    "hydrant":          r"hydrant",
    "bin":              r"\bbins?\b|trash|rubbish|litter|garbage|dustbin|waste",
    "hedge":            r"hedge|bush",
    "bike":             r"\bbikes?\b|bicycle|cycle",
    "motorbike":        r"motorbike|motorcycle",
    "pole":             r"\bpoles?\b|pylon",
    "lamp":             r"lamp|street ?light",
    "letter box":       r"post ?box|letter ?box|mail ?box|pillar box",
    "bench":            r"bench",
}

# ---------------------------------------------------------------- not reused from sets 7, 8, 9 and 10
# Sets 7-9: copied from set10/gen.py. Set 10: taken from set10/gen.py's spec (routes, named
# objects, nearest answers). prepare() also re-derives objects, answers, (label, place) pairs,
# count_within pairs, distance pairs and segments asked by id from the cyphers and truths of
# ../set7-10/questions.jsonl, so an item missing from these lists is still caught.
PREV_ROUTES = {(2352, 2361), (2358, 2362), (2353, 2361), (2354, 2360), (2355, 2362), (2359, 2360),
               (2353, 2358), (2356, 2362), (2354, 2361), (2360, 2362), (2352, 2358), (2356, 2360),  # sets 7-8
               (2352, 2360), (2353, 2356), (2353, 2359), (2354, 2357), (2355, 2361), (2361, 2362),  # set 9
               (2352, 2357), (2360, 2361), (2353, 2360), (2357, 2362), (2353, 2362), (2355, 2360)}  # set 10
PREV_OBJECTS = {966, 167, 237, 1796, 1269, 1737, 2213, 1016, 831, 1130, 1277, 1439, 14, 836, 1897,
                1989, 1054, 64, 1073, 404, 1392, 124, 1303, 1342,                        # set 7
                2056, 1734, 892, 2016, 1053, 1274, 1764, 2215, 86, 1263, 12, 692, 1062, 1360,
                996, 2128, 495, 1276, 1915, 1776,                                        # set 8
                13, 200, 219, 268, 296, 327, 428, 449, 631, 669, 671, 834, 839, 840, 963, 1019,
                1087, 1207, 1273, 1275, 1595, 1743, 1793, 1858, 1868, 2089, 2206, 2216,  # set 9
                2208, 1086, 115, 1787, 2063, 1017, 229, 604, 1848, 646, 543, 964, 1293, 166,
                1359, 1414, 171, 2018, 1514, 1248, 1126, 1797}                           # set 10
PREV_NEAREST_ANSWERS = {1016, 990, 836, 452, 1064, 101, 1439, 203, 1737, 656, 900,        # sets 7-8
                        16, 271, 418, 960, 1605, 1766,                                    # set 9
                        2001, 814, 381, 269, 1119, 676}                                   # set 10
PREV_WITHIN = {("letter box", 2338), ("hatchback", 2351), ("traffic light", 2332), ("hydrant", 2345),
               ("rubbish bin", 2341), ("hatchback", 2343), ("rubbish bin", 2349), ("hatchback", 2339),
               ("letter box", 2344), ("suv", 2348), ("hydrant", 2343), ("trailer", 2350),
               ("hydrant", 2344), ("rubbish bin", 2346), ("scooter", 2348), ("speed limit sign", 2341),
               ("suv", 2339), ("traffic light", 2334)}
PREV_REF_LABEL = {("rubbish bin", ("segment", 2346)), ("letter box", ("lane", 2357)), ("hydrant", ("start", None)),
                  ("speed limit sign", ("segment", 2332)), ("letter box", ("segment", 2343)),
                  ("hydrant", ("end", None)), ("rubbish bin", ("segment", 2347)), ("trailer", ("lane", 2353)),
                  ("letter box", ("lane", 2361)), ("hatchback", ("segment", 2351)),
                  ("trailer", ("segment", 2343)), ("rubbish bin", ("start", None)), ("letter box", ("segment", 2345)),
                  ("hydrant", ("lane", 2359)), ("letter box", ("segment", 2339)), ("trailer", ("lane", 2362)),
                  ("camper van", ("segment", 2345)), ("hatchback", ("lane", 2352)), ("hydrant", ("object", 327)),
                  ("letter box", ("end", None)), ("letter box", ("segment", 2340)), ("rubbish bin", ("object", 2089)),
                  ("rubbish bin", ("object", 839)), ("scooter", ("segment", 2337)), ("suv", ("lane", 2355)),
                  ("traffic light", ("object", 268)), ("traffic light", ("start", None)), ("trailer", ("object", 1793))}
PREV_DIST = {(("segment", 2338), ("segment", 2351)), (("start", None), ("lane", 2357)),
             (("object", 1342), ("segment", 2335)), (("end", None), ("segment", 2342)),
             (("lane", 2356), ("lane", 2360)), (("segment", 2347), ("object", 892)), (("start", None), ("lane", 2358)),
             (("start", None), ("end", None)), (("object", 1207), ("lane", 2358)), (("object", 1273), ("object", 449)),
             (("object", 1019), ("object", 1743)), (("object", 669), ("lane", 2362)), (("segment", 2337), ("segment", 2330))}
PREV_SETS = ("set7", "set8", "set9", "set10")
MAX_ROUTE_USES = 2   # only 3 lane-node pairs are left (see README); each is asked twice, once each way

# ---------------------------------------------------------------- the spec
# add(voice, kind, question, truth, cypher, calc, desc=..., **kw); desc entries are
#   (object id, noun key, colour|None, [attribute regexes] (each must match some caption), segment|None)

def seg_kind(seg):
    """segment_kind asked of a segment named by id (no object): the segment's own kind."""
    return f"MATCH (s:Segment) WHERE id(s) = {seg} RETURN id(s) AS id, s.kind AS kind"

# Description shorthands (each audited to match exactly one Instance under the broad reading).
SMALL_YELLOW_HB_DUSTY = (72, "hatchback", "yellow", [r"\bsmall\b", r"with dusty windows"], None)
COMPACT_SILVER_CAR = (1089, "car", "silver", [r"\bcompact\b"], None)
OLD_BLUE_BIKE_STAND = (80, "bike", "blue", [r"\bold\b", r"leaning on its stand"], None)
MIDSIZE_SUV_CURB_2338 = (11, "suv", None, [r"mid-size", r"parked by the curb"], 2338)
LAMP_2329 = (630, "lamp", None, [], 2329)
SMALL_GREEN_BIN = (736, "bin", "green", [r"\bsmall\b"], None)
SHORT_BROWN_BENCH = (92, "bench", "brown", [r"\bshort\b"], None)
SILVER_SUV_CURB = (168, "suv", "silver", [r"parked by the curb"], None)
MIDSIZE_BLUE_SUV = (1075, "suv", "blue", [r"mid-size"], None)
SMALL_SILVER_CITY_BIKE = (987, "bike", "silver", [r"\bsmall\b", r"city bike"], None)
MIDSIZE_YELLOW_CAR_DUSTY = (417, "car", "yellow", [r"mid-size", r"with dusty windows"], None)
MIDSIZE_HB_2341 = (496, "hatchback", None, [r"mid-size"], 2341)
HB_CURB_2343 = (965, "hatchback", None, [r"parked by the curb"], 2343)
SMALL_GREY_HB = (667, "hatchback", "grey", [r"\bsmall\b"], None)
OLD_BLACK_BENCH_STREET = (463, "bench", "black", [r"\bold\b", r"facing the street"], None)
SMALL_RED_HB_DUSTY = (662, "hatchback", "red", [r"\bsmall\b", r"with dusty windows"], None)
COMPACT_YELLOW_CAR_LANE = (1206, "car", "yellow", [r"\bcompact\b", r"parked in the parking lane"], None)
SMALL_BLUE_HB_LANE = (165, "hatchback", "blue", [r"\bsmall\b", r"parked in the parking lane"], None)
SMALL_CITY_BIKE_2351 = (672, "bike", None, [r"\bsmall\b", r"city bike", r"parked on the sidewalk"], 2351)
SMALL_LETTER_BOX_2344 = (1123, "letter box", None, [r"\bsmall\b", r"on the sidewalk"], 2344)

# ===== Voice K: someone talking to a voice assistant at home, fillers and hedges
K = "K-voice-assistant-at-home"
add(K, "count", "Um, so, could you tell me roughly how many camper vans there are on the map? Like, in total, the whole thing.",
    {"count": 3}, q_count("camper van"), "count", label="camper van")
add(K, "count", "Hey, I was wondering, if it's not too much trouble... how many speed limit signs are there altogether on the map?",
    {"count": 7}, q_count("speed limit sign"), "count", label="speed limit sign")
within(K, "Okay, um, so in segment 2343, how many rubbish bins are there? Just in that segment, I mean.",
       {"count": 2}, "rubbish bin", 2343)
within(K, "Hmm, I was wondering, are there any trailers in segment 2330? Er, how many, if there are?",
       {"count": 1}, "trailer", 2330)
add(K, "count_segments", "So, um, how many road segments does the map have in total? All of them, whatever kind they are.",
    {"count": 23}, Q_ALL_SEGMENTS, "count")
add(K, "count_segments", "Hey, um, could you tell me how many of the segments are T-junctions? Just the T-junctions, not the crossroads or the bends.",
    {"count": 2}, q_count_segments(["t_intersection"]), "count")
near(K, "Uh, so I'm kind of at lane node 2357 right now, and I was wondering how many trailers are within, let's say, 65 metres of me? In a straight line, I guess.",
     {"count": 2}, "trailer", ("lane", 2357), 65)
near(K, "If it's not too much trouble, um, how many fire hydrants are there within 75 metres of lane node 2361? Straight-line distance is fine.",
     {"count": 2}, "hydrant", ("lane", 2361), 75)
nearest(K, "Um, okay, which letter box is the closest one to the middle of segment 2330? Could you give me its id, please?",
        {"id": 77}, "letter box", ("segment", 2330))
nearest(K, "So, er, from the place where the survey drive started, which speed limit sign is nearest? I think I need its id, if that's okay.",
        {"id": 609}, "speed limit sign", ("start", None))
distance(K, "Um, I was wondering, roughly how far apart are the small green rubbish bin and the short brown park bench? Just as the crow flies, in metres.",
         {"distance_m": 78.84}, ("object", 736), ("object", 92), desc=[SMALL_GREEN_BIN, SHORT_BROWN_BENCH])
distance(K, "Hey, so, how far is it, in a straight line, from where the survey drive started to the silver SUV parked by the curb? In metres, please.",
         {"distance_m": 101.05}, ("start", None), ("object", 168), desc=[SILVER_SUV_CURB])
route(K, "Um, if I had to drive from lane node 2353 to lane node 2355, sticking to the lanes, how long would the shortest route be? In metres, I mean.",
      {"length_m": 181.32}, 2353, 2355)
route(K, "Okay, so, er, what's the length of the shortest route along the lanes from lane node 2353 to lane node 2357? Roughly in metres is fine.",
      {"length_m": 265.2}, 2353, 2357)
add(K, "segment", "Um, there's this small yellow hatchback with dusty windows... which segment is it in? Could you give me the segment id?",
    {"id": 2338}, q_segment(72), "segment", desc=[SMALL_YELLOW_HB_DUSTY])
add(K, "segment", "So I was wondering, if it's not too much trouble, which segment is the compact silver car in? Just the segment id, please.",
    {"id": 2350}, q_segment(1089), "segment", desc=[COMPACT_SILVER_CAR])
add(K, "segment_kind", "Um, the old blue bike that's leaning on its stand, what kind of road is that on? Like a straight road, a bend, a T-junction or a crossroads?",
    {"kind": "straight_road"}, q_segment(80), "segment_kind", desc=[OLD_BLUE_BIKE_STAND])
add(K, "segment_kind", "Hmm, so what sort of segment is segment 2337, do you know? Is it a straight road, a bend, a T-junction or a crossroads?",
    {"kind": "bend"}, seg_kind(2337), "segment_kind")
add(K, "colour", "Um, I was wondering what colour the mid-size SUV parked by the curb in segment 2338 is?",
    {"colour": "white"}, q_colour(11), "colour", desc=[MIDSIZE_SUV_CURB_2338])
add(K, "colour", "Okay, er, there's a street lamp in segment 2329, I think just the one. What colour is it, roughly?",
    {"colour": "black"}, q_colour(630), "colour", desc=[LAMP_2329])

# ===== Voice L: GIS analyst, technical spatial vocabulary
L = "L-gis-analyst"
add(L, "count", "Return the total feature count for the rubbish bin class across the full map extent.",
    {"count": 19}, q_count("rubbish bin"), "count", label="rubbish bin")
add(L, "count", "What is the feature count of SUVs over the entire study area, no spatial filter applied?",
    {"count": 12}, q_count("suv"), "count", label="suv")
within(L, "Feature count of fences assigned to segment polygon 2344?",
       {"count": 3}, "fence", 2344)
within(L, "Give the number of SUV features contained in segment id 2338 (point-in-segment assignment).",
       {"count": 2}, "suv", 2338)
add(L, "count_segments", "How many segment polygons are classified as junctions of any type, i.e. crossroads, T-junctions or bends, excluding the straight road class?",
    {"count": 9}, q_count_segments(["intersection", "t_intersection", "l_intersection"]), "count")
add(L, "count_segments", "Count the segments whose class is either straight road or T-junction; crossroads and bends are excluded from the selection.",
    {"count": 16}, q_count_segments(["straight_roadway", "t_intersection"]), "count")
near(L, "Within a 55 m buffer of lane node 2358 (Euclidean distance in the ground plane), what is the feature count of sedans?",
     {"count": 2}, "sedan", ("lane", 2358), 55)
near(L, "Using the centroid of segment 2338 as the origin, how many traffic lights fall within a 75 m radius, Euclidean distance in the ground plane?",
     {"count": 4}, "traffic light", ("segment", 2338), 75)
nearest(L, "Nearest-neighbour query: which rubbish bin has the smallest Euclidean distance to the centroid of segment 2339? Return its feature id.",
        {"id": 158}, "rubbish bin", ("segment", 2339))
nearest(L, "Return the feature id of the SUV nearest to lane node 2354, Euclidean distance in the ground plane.",
        {"id": 220}, "suv", ("lane", 2354))
distance(L, "Compute the Euclidean distance in the ground plane between the centroid of segment 2340 and the centroid of segment 2349, in metres.",
         {"distance_m": 112.87}, ("segment", 2340), ("segment", 2349))
distance(L, "What is the Euclidean ground-plane distance from the small grey hatchback's centroid to the centroid of segment 2345, in metres?",
         {"distance_m": 156.97}, ("object", 667), ("segment", 2345), desc=[SMALL_GREY_HB])
route(L, "Network distance along the lane graph from lane node 2357 to lane node 2353: report the shortest-path length in metres.",
      {"length_m": 265.2}, 2357, 2353)
route(L, "Compute the shortest-path network distance along the lane graph between lane node 2356 and lane node 2361, in metres.",
      {"length_m": 157.85}, 2356, 2361)
add(L, "segment", "Which segment polygon contains the mid-size blue SUV? Return the segment id.",
    {"id": 2348}, q_segment(1075), "segment", desc=[MIDSIZE_BLUE_SUV])
add(L, "segment", "Point-in-polygon lookup: return the segment id assigned to the small silver city bike.",
    {"id": 2343}, q_segment(987), "segment", desc=[SMALL_SILVER_CITY_BIKE])
add(L, "segment_kind", "What is the class attribute of segment id 2331: straight road, bend, T-junction or crossroads?",
    {"kind": "t_junction"}, seg_kind(2331), "segment_kind")
add(L, "segment_kind", "For the segment containing the mid-size yellow car with dusty windows, return the segment class (straight road, bend, T-junction or crossroads).",
    {"kind": "straight_road"}, q_segment(417), "segment_kind", desc=[MIDSIZE_YELLOW_CAR_DUSTY])
add(L, "colour", "Return the colour attribute of the mid-size hatchback feature in segment 2341.",
    {"colour": "grey"}, q_colour(496), "colour", desc=[MIDSIZE_HB_2341])
add(L, "colour", "Attribute query: colour of the hatchback parked by the curb within segment id 2343?",
    {"colour": "green"}, q_colour(965), "colour", desc=[HB_CURB_2343])

# ===== Voice M: tourist texting on a phone, lowercase, abbreviations, a few typos
M = "M-tourist-texting"
add(M, "count", "hw many letter boxes r there on the whole map? need to post sum postcards lol",
    {"count": 11}, q_count("letter box"), "count", label="letter box")
add(M, "count", "hey quick q how many traffic lights does teh map have in total",
    {"count": 18}, q_count("traffic light"), "count", label="traffic light")
within(M, "hw many traffic lights in segment 2335 pls",
       {"count": 2}, "traffic light", 2335)
within(M, "how many sedans r parked in segment 2351? looking for my frends car",
       {"count": 2}, "sedan", 2351)
add(M, "count_segments", "hw many segments r straight roads or bends? not junctions w 3 or 4 roads, just those two",
    {"count": 18}, q_count_segments(["straight_roadway", "l_intersection"]), "count")
add(M, "count_segments", "how many crossroads r on the map, the propper 4 way ones only",
    {"count": 3}, q_count_segments(["intersection"]), "count")
near(M, "im at lane node 2362 rn, hw many letter boxes within 120 m of me? straight line pls",
     {"count": 2}, "letter box", ("lane", 2362), 120)
near(M, "how many rubbish bins within 35 metres of the middle of segment 2341 pls, as the crow flys",
     {"count": 2}, "rubbish bin", ("segment", 2341), 35)
nearest(M, "where the survey drive ended, which traffic light is closest?? need its id",
        {"id": 634}, "traffic light", ("end", None))
nearest(M, "standing at lane node 2355 rn, whats the id of the nearest hatchback",
        {"id": 424}, "hatchback", ("lane", 2355))
distance(M, "hw far is it from where the survey drive ended to lane node 2362? straight line in metres pls",
         {"distance_m": 57.92}, ("end", None), ("lane", 2362))
distance(M, "how far is the old black bench facing the street from lane node 2356, as the crow flys, in m",
         {"distance_m": 108.36}, ("object", 463), ("lane", 2356), desc=[OLD_BLACK_BENCH_STREET])
route(M, "shortest way from lane node 2361 to lane node 2356 using only the lanes, hw long in metres?",
      {"length_m": 157.85}, 2361, 2356)
route(M, "driving from lane node 2355 to lane node 2353 on the lanes, whats the shortest route lenght in m",
      {"length_m": 181.32}, 2355, 2353)
add(M, "segment", "which segment is the small red hatchback with dusty windows in? need the segment id thx",
    {"id": 2351}, q_segment(662), "segment", desc=[SMALL_RED_HB_DUSTY])
add(M, "segment", "the compact yellow car parked in the parking lane, wich segment is it in pls",
    {"id": 2345}, q_segment(1206), "segment", desc=[COMPACT_YELLOW_CAR_LANE])
add(M, "segment_kind", "the small blue hatchback parked in the parking lane - is it on a straight road, a bend, a t-junction or a crossroads?",
    {"kind": "straight_road"}, q_segment(165), "segment_kind", desc=[SMALL_BLUE_HB_LANE])
add(M, "segment_kind", "wat kind of segment is segment 2332? straight road, bend, t-junction or crossroads",
    {"kind": "crossroads"}, seg_kind(2332), "segment_kind")
add(M, "colour", "what colour is the small city bike parked on the sidewalk in segment 2351? think its mine lol",
    {"colour": "blue"}, q_colour(672), "colour", desc=[SMALL_CITY_BIKE_2351])
add(M, "colour", "wat colour is the small letter box on the sidewalk in segment 2344",
    {"colour": "red"}, q_colour(1123), "colour", desc=[SMALL_LETTER_BOX_2344])

# ---------------------------------------------------------------- set 11's own audits (set 10's, extended)
def prepare():
    """Set 11's per-question audit: no reuse of sets 7-10 (by id and by place: a lane node sits on
    a junction segment's centroid), no single-edge route, each route pair at most twice (once
    each way), no repeated text, broad fence count, a segment asked by id not asked before."""
    lane_adj = {tuple(sorted((r["a"], r["b"]))) for r in run(Q_LANES)}
    previous = askgen.other_set_questions(HERE)
    P = askgen.prev_from_files(HERE, PREV_SETS)
    objs = run(Q_ALL)
    pts = askgen.ref_points()

    def place(ref):
        x, z = pts[tuple(ref)]
        return (round(x, 1), round(z, 1))

    prev_objects = PREV_OBJECTS | P["objects"]
    prev_answers = PREV_NEAREST_ANSWERS | P["answers"]
    prev_within = PREV_WITHIN | P["within"]
    prev_reflabel = {(lab, place(r)) for lab, r in PREV_REF_LABEL | P["reflabel"]}
    prev_dist = {frozenset((place(a), place(b))) for a, b in PREV_DIST | P["dist"]}
    seen_objects = {}
    route_uses = Counter(); route_dirs = {}
    own_answers = set()

    def audit(q, probs):
        if q["question"].strip().lower() in previous:
            probs.append("question text already used in another set")
        named = [d[0] for d in q["desc"]]
        for oid in named:
            if oid in prev_objects or oid in prev_answers:
                probs.append(f"object {oid} was already named or answered in sets 7-10")
            if oid in seen_objects and seen_objects[oid] != q["question"]:
                probs.append(f"object {oid} is named by two set-11 questions")
            if oid in own_answers:
                probs.append(f"object {oid} is also a nearest answer in set 11")
            seen_objects[oid] = q["question"]
        if q["calc"] == "route":
            pair = tuple(sorted((q["src"], q["dst"])))
            if pair in PREV_ROUTES:
                probs.append(f"route pair {pair} already used in sets 7-10")
            if pair in lane_adj:
                probs.append(f"route pair {pair} is a single LANE edge")
            route_uses[pair] += 1
            if route_uses[pair] > MAX_ROUTE_USES:
                probs.append(f"route pair {pair} asked more than {MAX_ROUTE_USES} times")
            if route_dirs.get(pair) == (q["src"], q["dst"]):
                probs.append(f"route pair {pair} asked twice in the same direction")
            route_dirs[pair] = (q["src"], q["dst"])
        if q["kind"] == "count_within":
            if (q["label"], q["seg"]) in prev_within:
                probs.append(f"count_within ({q['label']}, {q['seg']}) already used in sets 7-10")
            if q["label"] in BROAD_COUNT:
                rx = re.compile(BROAD_COUNT[q["label"]], re.I)
                n = sum(1 for o in objs if q["seg"] in o["segs"] and
                        any(rx.search(c) for c in (o["captions"] or []) + [o["label"] or ""]))
                if n != q["truth"]["count"]:
                    probs.append(f"broad count ({BROAD_COUNT[q['label']]}) in segment {q['seg']} is {n}")
        if q["kind"] in ("count_near", "nearest"):
            if (q["label"], place(q["ref"])) in prev_reflabel:
                probs.append(f"({q['label']}, {q['ref']}) already used in sets 7-10 (same place)")
            if q["ref"][0] == "object" and (q["ref"][1] in prev_objects or q["ref"][1] in prev_answers):
                probs.append(f"reference object {q['ref'][1]} already named in sets 7-10")
        if q["kind"] == "nearest":
            ans = q["truth"]["id"]
            if ans in prev_answers or ans in prev_objects:
                probs.append(f"nearest answer {ans} already an answer or target in sets 7-10")
            if ans in seen_objects or ans in own_answers:
                probs.append(f"nearest answer {ans} is also named or answered elsewhere in set 11")
            own_answers.add(ans)
        if q["kind"] == "distance":
            a, b = (tuple(x) for x in q["pair"])
            if frozenset((place(a), place(b))) in prev_dist:
                probs.append(f"distance pair {a}-{b} already used in sets 7-10 (same places)")
            for r in (a, b):
                if r[0] == "object" and (r[1] in prev_objects or r[1] in prev_answers):
                    probs.append(f"object {r[1]} already named in sets 7-10")
        if q["kind"] == "segment_kind" and not q["desc"]:
            # a segment asked about by id: the question names it, and the cypher is that segment's own
            m = askgen.SEG_KIND_BY_ID.match(q["cypher"])
            if not m or f"segment {m.group(1)}" not in q["question"].lower() and f"segment id {m.group(1)}" not in q["question"].lower():
                probs.append("segment_kind by id: segment not named in the question")
            elif int(m.group(1)) in P["segkind"]:
                probs.append(f"segment {m.group(1)} already asked by id in sets 7-10")
    return audit

def main():
    check(here=HERE, og_default=OG_DEFAULT, db_default=DB_DEFAULT, kinds=KINDS, nouns=NOUNS,
          prepare=prepare, pass_note=", no reuse of sets 7-10")

if __name__ == "__main__":
    main()
