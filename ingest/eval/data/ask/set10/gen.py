#!/usr/bin/env python3
"""Held-out question set 10: spec, truth recomputation and audits.

Usage:
  python3 gen.py           # re-run every cypher, recompute truths, run audits, compare with questions.jsonl
  python3 gen.py --write   # same, then (re)write questions.jsonl from the spec (only if everything passes)

Environment:
  OPENGRAPH          the opengraph CLI (default /tmp/ask8/opengraph)
  OPENGRAPH_ASK_DB   the map store   (default /tmp/ask8/city.og; the default small city,
                     `opengraph sim --size small --seed 0` + `opengraph build`, commit e5afdf6;
                     the same map as sets 8 and 9)

Every query is run with --read-only. Ground plane is (x, z); y is up.

This file holds only what is set 10's own (defaults, vocabulary, questions and its audits: reuse of
sets 7-9, coinciding reference points, a broad fence count). The helpers shared by sets 7-10
(cypher builders, running the queries, truth recomputation, the common audits, the PASS/FAIL
report) are in ../askgen.py.
"""
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))   # for ../askgen.py
from askgen import Q_ALL, Q_LANES, add, distance, near, nearest, route, run, within  # noqa: E402
from askgen import q_colour, q_count, q_count_segments, q_segment, main as check  # noqa: E402
import askgen  # noqa: E402

OG_DEFAULT = "/tmp/ask8/opengraph"   # $OPENGRAPH
DB_DEFAULT = "/tmp/ask8/city.og"     # $OPENGRAPH_ASK_DB

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
    "scooter":          r"scooter|moped",
    "speed limit sign": r"speed limit|speed sign",
    "camper van":       r"camper|motorhome|\bvan\b|\brv\b",
    "minibus":          r"mini-? ?bus|\bbus\b(?!\s*(stop|shelter))",
    "sedan":            r"sedan|saloon",
    "fence":            r"fence",
}
# For count_within, the count under a broader reading of the noun must equal the truth too
# (a reader may take a railing for a fence). Checked by set 10's own audit.
BROAD_COUNT = {"fence": r"fence|railing"}

# Nouns used in descriptions of single objects (broad readings: label or any caption).
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
}

# ---------------------------------------------------------------- not reused from sets 7, 8 and 9
# Copied from set9/gen.py (sets 7 and 8) plus set 9's own, taken from set9/gen.py's spec.
# prepare() also re-derives objects, answers and (label, place) pairs from the cyphers of
# ../set7-9/questions.jsonl, so a pair missing from these lists is still caught.
PREV_ROUTES = {(2352, 2361), (2358, 2362), (2353, 2361), (2354, 2360), (2355, 2362), (2359, 2360),
               (2353, 2358), (2356, 2362), (2354, 2361), (2360, 2362), (2352, 2358), (2356, 2360),  # sets 7-8
               (2352, 2360), (2353, 2356), (2353, 2359), (2354, 2357), (2355, 2361), (2361, 2362)}  # set 9
PREV_OBJECTS = {966, 167, 237, 1796, 1269, 1737, 2213, 1016, 831, 1130, 1277, 1439, 14, 836, 1897,
                1989, 1054, 64, 1073, 404, 1392, 124, 1303, 1342,                        # set 7
                2056, 1734, 892, 2016, 1053, 1274, 1764, 2215, 86, 1263, 12, 692, 1062, 1360,
                996, 2128, 495, 1276, 1915, 1776,                                        # set 8
                13, 200, 219, 268, 296, 327, 428, 449, 631, 669, 671, 834, 839, 840, 963, 1019,
                1087, 1207, 1273, 1275, 1595, 1743, 1793, 1858, 1868, 2089, 2206, 2216}  # set 9
PREV_NEAREST_ANSWERS = {1016, 990, 836, 452, 1064, 101, 1439, 203, 1737, 656, 900,        # sets 7-8
                        16, 271, 418, 960, 1605, 1766}                                    # set 9
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

# ---------------------------------------------------------------- the spec
# add(voice, kind, question, truth, cypher, calc, desc=..., **kw); desc entries are
#   (object id, noun key, colour|None, [attribute regexes] (each must match some caption), segment|None)

def seg_kind(seg):
    """segment_kind asked of a segment named by id (no object): the segment's own kind."""
    return f"MATCH (s:Segment) WHERE id(s) = {seg} RETURN id(s) AS id, s.kind AS kind"

# Description shorthands (each audited to match exactly one Instance under the broad reading).
LARGE_SILVER_DUSTY_CAR = (2208, "car", "silver", [r"\blarge\b", r"dusty windows"], None)
COMPACT_GREEN_CAR_CURB = (1086, "car", "green", [r"compact", r"parked by the curb"], None)
LONE_BUSH = (115, "hedge", "green", [r"\bbush\b", r"\blow\b", r"along a garden"], None)
MOTORCYCLE_2348 = (1787, "motorbike", None, [r"kickstand"], 2348)
LETTER_BOX_2350 = (2063, "letter box", None, None, 2350)
OLD_RED_CITY_BIKE = (1017, "bike", "red", [r"\bold\b", r"city bike", r"leaning on its stand"], None)
TALL_GREEN_CABLE_POLE = (229, "pole", "green", [r"\btall\b", r"carrying cables"], None)
LARGE_GREEN_PLASTIC_BIN = (604, "bin", "green", [r"\blarge\b", r"plastic", r"on the sidewalk"], None)
LARGE_GREEN_BIN_LAMP = (1848, "bin", "green", [r"\blarge\b", r"by a lamp post"], None)
SHORT_YELLOW_HYDRANT = (646, "hydrant", "yellow", [r"\bshort\b", r"on the sidewalk"], None)
SMALL_GREEN_HB_CURB = (543, "hatchback", "green", [r"\bsmall\b", r"parked by the curb"], None)
MIDSIZE_SILVER_HB_LANE = (964, "hatchback", "silver", [r"mid-size", r"parked in the parking lane"], None)
NEW_YELLOW_BIKE = (1293, "bike", "yellow", [r"\bnew\b", r"parked on the sidewalk"], None)
COMPACT_BLACK_CAR_CURB = (166, "car", "black", [r"compact", r"parked by the curb"], None)
MIDSIZE_HB_CURB_2346 = (1359, "hatchback", None, [r"mid-size", r"parked by the curb"], 2346)
OLD_LAMP_2336 = (1414, "lamp", None, [r"old-fashioned", r"over the road"], 2336)
OLD_RED_BIKE_SIDEWALK = (171, "bike", "red", [r"\bold\b", r"parked on the sidewalk"], None)
SILVER_CITY_BIKE_STAND = (2018, "bike", "silver", [r"city bike", r"leaning on its stand"], None)
SHORT_RED_HYDRANT = (1514, "hydrant", "red", [r"\bshort\b", r"on the sidewalk"], None)
OLD_YELLOW_BIKE = (1248, "bike", "yellow", [r"\bold\b", r"parked on the sidewalk"], None)
BIKE_2344 = (1126, "bike", None, None, 2344)
COMPACT_SUV_2348 = (1797, "suv", None, [r"compact"], 2348)

# ===== Voice J: robot / vehicle operator on the radio, terse, call signs and "over"
J = "J-robot-radio-operator"
add(J, "count", "Rover Three to Base. Request total count of fire hydrants, whole map. Over.",
    {"count": 9}, q_count("hydrant"), "count", label="hydrant")
add(J, "count", "Base, this is Unit 7. What's the tally of trailers across the entire map? Over.",
    {"count": 8}, q_count("trailer"), "count", label="trailer")
within(J, "Unit 4 to Base: count of traffic lights, segment 2329, over.",
       {"count": 3}, "traffic light", 2329)
within(J, "Rover Two to Base, request number of hydrants located in segment 2342. Over.",
       {"count": 2}, "hydrant", 2342)
add(J, "count_segments", "Unit 9 to Base: how many crossroads segments on the map? Four-way crossroads only, no T-junctions, no bends. Over.",
    {"count": 3}, q_count_segments(["intersection"]), "count")
add(J, "count_segments", "Base, Unit 9 again. Need number of road segments that are NOT crossroads - straight roads, T-junctions and bends all included. Over.",
    {"count": 20}, q_count_segments(["t_intersection", "l_intersection", "straight_roadway"]), "count")
near(J, "Rover Three to Base: from the start point of the survey drive, count hatchbacks within 45 metres, straight line. Over.",
     {"count": 4}, "hatchback", ("start", None), 45)
near(J, "Unit 4 to Base, my position is lane node 2361. How many traffic lights within 65 metres of my position, straight line? Over.",
     {"count": 4}, "traffic light", ("lane", 2361), 65)
nearest(J, "Unit 6 to Base: holding at lane node 2357. Request id of the nearest hydrant. Over.",
        {"id": 2001}, "hydrant", ("lane", 2357))
nearest(J, "Base, Rover One. Which trailer is closest to the start point of the survey drive? Send its node id. Over.",
        {"id": 814}, "trailer", ("start", None))
distance(J, "Unit 2 to Base: straight-line distance between lane node 2352 and lane node 2361, in metres. Over.",
         {"distance_m": 170.03}, ("lane", 2352), ("lane", 2361))
distance(J, "Rover Three to Base, request metres separating the start point of the survey drive from the centre of segment 2344, as the crow flies. Over.",
         {"distance_m": 110.67}, ("start", None), ("segment", 2344))
route(J, "Unit 5 to Base: plotting a drive from lane node 2352 to lane node 2357, lanes only. Length of the shortest route in metres? Over.",
      {"length_m": 183.5}, 2352, 2357)
route(J, "Base from Unit 8. Shortest lane-following route, lane node 2360 to lane node 2361. Report length in metres. Over.",
      {"length_m": 133.48}, 2360, 2361)
add(J, "segment", "Unit 3 to Base: eyes on a large silver car with dusty windows. Which segment is it in? Send segment id. Over.",
    {"id": 2351}, q_segment(2208), "segment", desc=[LARGE_SILVER_DUSTY_CAR])
add(J, "segment", "Rover Two to Base, compact green car parked by the curb. Confirm its segment id. Over.",
    {"id": 2348}, q_segment(1086), "segment", desc=[COMPACT_GREEN_CAR_CURB])
add(J, "segment_kind", "Unit 4 to Base: the lone low dark-green bush along a garden - a single bush, not a row of bushes or a hedge. What type of segment is it on: straight road, bend, T-junction or crossroads? Over.",
    {"kind": "bend"}, q_segment(115), "segment_kind", desc=[LONE_BUSH])
add(J, "segment_kind", "Base, Unit 1. Confirm segment type for segment 2335: straight road, bend, T-junction or crossroads? Over.",
    {"kind": "t_junction"}, seg_kind(2335), "segment_kind")
add(J, "colour", "Rover Three to Base: motorcycle standing on its kickstand, segment 2348. Request its colour. Over.",
    {"colour": "blue"}, q_colour(1787), "colour", desc=[MOTORCYCLE_2348])
add(J, "colour", "Unit 7 to Base, the letter box in segment 2350: what colour is it on record? Over.",
    {"colour": "yellow"}, q_colour(2063), "colour", desc=[LETTER_BOX_2350])

# ===== Voice K: city-planning committee member, long formal questions with subordinate clauses
K = "K-planning-committee-formal"
add(K, "count", "In preparing the committee's report on kerbside parking demand, which, as members will recall, was deferred at the last sitting pending better data, I should be grateful if the officers could state the total number of minibuses that the map records across the whole of the area.",
    {"count": 3}, q_count("minibus"), "count", label="minibus")
add(K, "count", "Since the question of whether residents' permits should be extended to smaller vehicles has been raised by several members, and since hatchbacks are thought to make up the bulk of such vehicles, could it be confirmed how many hatchbacks appear on the map in total?",
    {"count": 20}, q_count("hatchback"), "count", label="hatchback")
within(K, "Given that the postal consultation, to which this committee is obliged to respond, concerns collection points along segment 2340 in particular, would the officers please establish how many letter boxes are situated within that segment?",
       {"count": 2}, "letter box", 2340)
within(K, "With regard to the boundary-treatment policy, under which the committee must consider whether further fencing would be appropriate along segment 2343, I would ask how many fences the map already records within that segment.",
       {"count": 4}, "fence", 2343)
add(K, "count_segments", "For the purposes of the junction-signalling review, in which only those junctions where three or four roads meet are being considered and the bends are therefore excluded, how many segments of the map are either crossroads or T-junctions?",
    {"count": 5}, q_count_segments(["intersection", "t_intersection"]), "count")
add(K, "count_segments", "Inasmuch as the full four-way crossroads have already been surveyed, the remaining junction work concerns the T-junctions and the bends; could the officers tell the committee how many segments fall into those two categories taken together?",
    {"count": 6}, q_count_segments(["t_intersection", "l_intersection"]), "count")
near(K, "The proposal for a residents' parking zone centred on the middle of segment 2344, which would extend 90 metres in every direction measured in a straight line, requires an estimate of the vehicles affected: how many SUVs lie within that radius?",
     {"count": 7}, "suv", ("segment", 2344), 90)
near(K, "It having been suggested that the old red city bike leaning on its stand has become something of a local landmark, and that a postal collection point near it would be welcome, could the committee be told how many letter boxes already stand within 45 metres of that bike, measured directly?",
     {"count": 5}, "letter box", ("object", 1017), 45, desc=[OLD_RED_CITY_BIKE])
nearest(K, "Before the committee approves the relocation of street furniture around lane node 2355, about which several residents have written, it would be helpful to know which rubbish bin is nearest to that node; would the officers supply its id?",
        {"id": 381}, "rubbish bin", ("lane", 2355))
nearest(K, "Because the tall green utility pole carrying cables is scheduled for replacement, and because the contractor has asked which signals might be affected by the works, could it be stated which traffic light is the closest to that pole, giving the light's id?",
        {"id": 269}, "traffic light", ("object", 229), desc=[TALL_GREEN_CABLE_POLE])
distance(K, "So that the committee may judge whether the litter provision near the end of the recent survey drive is adequate, would the officers state the straight-line distance, in metres, between the point at which the survey drive ended and the large green plastic trash can on the sidewalk?",
         {"distance_m": 46.33}, ("end", None), ("object", 604), desc=[LARGE_GREEN_PLASTIC_BIN])
distance(K, "In order that the emergency-access audit, which was commissioned following last winter's incident, may proceed, I should like to know the gap, in metres and as the crow flies, between the large green trash can by a lamp post and the short yellow hydrant on the sidewalk.",
         {"distance_m": 209.04}, ("object", 1848), ("object", 646), desc=[LARGE_GREEN_BIN_LAMP, SHORT_YELLOW_HYDRANT])
route(K, "Were the proposed shuttle vehicle, which would be required to keep to the lanes at all times, to run from lane node 2353 to lane node 2360, what would be the length in metres of the shortest route available to it?",
      {"length_m": 346.55}, 2353, 2360)
route(K, "Whereas a straight-line figure would understate the journey, the committee would prefer to know the length of the shortest route along the lane network between lane node 2357 and lane node 2362, expressed in metres.",
      {"length_m": 255.05}, 2357, 2362)
add(K, "segment", "As the small green hatchback parked by the curb has been the subject of a number of complaints, which the committee is minded to refer to the enforcement team, would the officers identify the segment in which it is recorded, by its segment id?",
    {"id": 2341}, q_segment(543), "segment", desc=[SMALL_GREEN_HB_CURB])
add(K, "segment", "Further to the enquiry about parking-lane usage, in which the mid-size silver hatchback parked in the parking lane was mentioned by name, could it be confirmed in which segment of the map that vehicle lies?",
    {"id": 2343}, q_segment(964), "segment", desc=[MIDSIZE_SILVER_HB_LANE])
add(K, "segment_kind", "Although the new yellow bike parked on the sidewalk is not itself a planning matter, the question of where cycle parking should go is; would the officers therefore say whether the segment on which that bike stands is a straight road, a bend, a T-junction or a crossroads?",
    {"kind": "straight_road"}, q_segment(1293), "segment_kind", desc=[NEW_YELLOW_BIKE])
add(K, "segment_kind", "Since the compact black car parked by the curb was cited in evidence at the last hearing, and since the type of road on which it stands is material to the objection, would it be confirmed whether its segment is a straight road, a bend, a T-junction or a crossroads?",
    {"kind": "straight_road"}, q_segment(166), "segment_kind", desc=[COMPACT_BLACK_CAR_CURB])
add(K, "colour", "For the sake of completeness in the committee's photographic record, which was found to be deficient at the last audit, what colour is the mid-size hatchback parked by the curb in segment 2346 recorded as?",
    {"colour": "silver"}, q_colour(1359), "colour", desc=[MIDSIZE_HB_CURB_2346])
add(K, "colour", "Given that the heritage officer has proposed repainting the old-fashioned street lamp over the road in segment 2336, it would assist members to know what colour that lamp is at present according to the map.",
    {"colour": "black"}, q_colour(1414), "colour", desc=[OLD_LAMP_2336])

# ===== Voice L: non-native speaker, simple grammar, some word-order mistakes
L = "L-non-native-simple"
add(L, "count", "How many scooter there is on the map? All of the map, please.",
    {"count": 3}, q_count("scooter"), "count", label="scooter")
add(L, "count", "Sedan, how many on the map they are? I want know the total number.",
    {"count": 6}, q_count("sedan"), "count", label="sedan")
within(L, "In segment 2331 how many traffic light is there?",
       {"count": 2}, "traffic light", 2331)
within(L, "Please, the number of SUV in segment 2350 you can tell me?",
       {"count": 1}, "suv", 2350)
add(L, "count_segments", "How many segment is straight road on the map? Not the junctions, only the straight.",
    {"count": 14}, q_count_segments(["straight_roadway"]), "count")
add(L, "count_segments", "Where the road make a turn, a bend, how many of this segment the map have? Not crossroad, not T-junction.",
    {"count": 4}, q_count_segments(["l_intersection"]), "count")
near(L, "Where the survey drive is finish, inside 55 metre from there, how many rubbish bin there are? Straight distance.",
     {"count": 5}, "rubbish bin", ("end", None), 55)
near(L, "I stand at lane node 2354. Hydrant inside 80 metre of me, how many is it?",
     {"count": 2}, "hydrant", ("lane", 2354), 80)
nearest(L, "Which speed limit sign is most near to the middle of segment 2344? Give me the id please.",
        {"id": 1119}, "speed limit sign", ("segment", 2344))
nearest(L, "From the end of the survey drive, the minibus which is most close, what is his id?",
        {"id": 676}, "minibus", ("end", None))
distance(L, "Middle of segment 2331 and middle of segment 2350, how much metre is between them? Straight line, not by the road.",
         {"distance_m": 203.71}, ("segment", 2331), ("segment", 2350))
distance(L, "The old red bike what is parked on the sidewalk, how far it is from lane node 2359? In straight line, metres.",
         {"distance_m": 136.27}, ("lane", 2359), ("object", 171), desc=[OLD_RED_BIKE_SIDEWALK])
route(L, "I must drive from lane node 2353 to lane node 2362 only on the lanes. The shortest way is how long, in metre?",
      {"length_m": 153.24}, 2353, 2362)
route(L, "Shortest route on lane network, lane node 2355 until lane node 2360, how many metres it is long?",
      {"length_m": 165.24}, 2355, 2360)
add(L, "segment", "The silver city bike who is leaning on its stand, in which segment it is? Segment id please.",
    {"id": 2350}, q_segment(2018), "segment", desc=[SILVER_CITY_BIKE_STAND])
add(L, "segment", "Short red fire hydrant on the sidewalk, it is in what segment? I need the number of segment.",
    {"id": 2340}, q_segment(1514), "segment", desc=[SHORT_RED_HYDRANT])
add(L, "segment_kind", "The old yellow bike parked on the sidewalk, is on what kind of road? Straight road, bend, T-junction or crossroads?",
    {"kind": "straight_road"}, q_segment(1248), "segment_kind", desc=[OLD_YELLOW_BIKE])
add(L, "segment_kind", "Segment 2334, what type of road it is? Straight, bend, T-junction or crossroads?",
    {"kind": "crossroads"}, seg_kind(2334), "segment_kind")
add(L, "colour", "Bike in segment 2344, which colour it have?",
    {"colour": "green"}, q_colour(1126), "colour", desc=[BIKE_2344])
add(L, "colour", "Compact SUV in the segment 2348, what is the colour of it?",
    {"colour": "grey"}, q_colour(1797), "colour", desc=[COMPACT_SUV_2348])

# ---------------------------------------------------------------- set 10's own audits
def prepare():
    """Set 10's per-question audit: no reuse of sets 7-9 (by id and by place: a lane node sits on
    a junction segment's centroid), no single-edge route, no repeated text, broad fence count."""
    lane_adj = {tuple(sorted((r["a"], r["b"]))) for r in run(Q_LANES)}
    previous = askgen.other_set_questions(HERE)
    P = askgen.prev_from_files(HERE, ("set7", "set8", "set9"))
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

    def audit(q, probs):
        if q["question"].strip().lower() in previous:
            probs.append("question text already used in another set")
        named = [d[0] for d in q["desc"]]
        for oid in named:
            if oid in prev_objects or oid in prev_answers:
                probs.append(f"object {oid} was already named or answered in sets 7-9")
            if oid in seen_objects and seen_objects[oid] != q["question"]:
                probs.append(f"object {oid} is named by two set-10 questions")
            seen_objects[oid] = q["question"]
        if q["calc"] == "route":
            pair = tuple(sorted((q["src"], q["dst"])))
            if pair in PREV_ROUTES:
                probs.append(f"route pair {pair} already used in sets 7-9")
            if pair in lane_adj:
                probs.append(f"route pair {pair} is a single LANE edge")
        if q["kind"] == "count_within":
            if (q["label"], q["seg"]) in prev_within:
                probs.append(f"count_within ({q['label']}, {q['seg']}) already used in sets 7-9")
            if q["label"] in BROAD_COUNT:
                rx = re.compile(BROAD_COUNT[q["label"]], re.I)
                n = sum(1 for o in objs if q["seg"] in o["segs"] and
                        any(rx.search(c) for c in (o["captions"] or []) + [o["label"] or ""]))
                if n != q["truth"]["count"]:
                    probs.append(f"broad count ({BROAD_COUNT[q['label']]}) in segment {q['seg']} is {n}")
        if q["kind"] in ("count_near", "nearest"):
            if (q["label"], place(q["ref"])) in prev_reflabel:
                probs.append(f"({q['label']}, {q['ref']}) already used in sets 7-9 (same place)")
            if q["ref"][0] == "object" and (q["ref"][1] in prev_objects or q["ref"][1] in prev_answers):
                probs.append(f"reference object {q['ref'][1]} already named in sets 7-9")
        if q["kind"] == "nearest":
            ans = q["truth"]["id"]
            if ans in prev_answers or ans in prev_objects:
                probs.append(f"nearest answer {ans} already an answer or target in sets 7-9")
        if q["kind"] == "distance":
            a, b = (tuple(x) for x in q["pair"])
            if frozenset((place(a), place(b))) in prev_dist:
                probs.append(f"distance pair {a}-{b} already used in sets 7-9 (same places)")
            for r in (a, b):
                if r[0] == "object" and (r[1] in prev_objects or r[1] in prev_answers):
                    probs.append(f"object {r[1]} already named in sets 7-9")
        if q["kind"] == "segment_kind" and not q["desc"]:
            # a segment asked about by id: the question names it, and the cypher is that segment's own
            m = re.search(r"id\(s\) = (\d+)", q["cypher"])
            if not m or f"segment {m.group(1)}" not in q["question"].lower():
                probs.append("segment_kind by id: segment not named in the question")
    return audit

def main():
    check(here=HERE, og_default=OG_DEFAULT, db_default=DB_DEFAULT, kinds=KINDS, nouns=NOUNS,
          prepare=prepare, pass_note=", no reuse of sets 7-9")

if __name__ == "__main__":
    main()
