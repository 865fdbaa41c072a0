#!/usr/bin/env python3
"""Held-out question set 9: spec, truth recomputation and audits.

Usage:
  python3 gen.py           # re-run every cypher, recompute truths, run audits, compare with questions.jsonl
  python3 gen.py --write   # same, then (re)write questions.jsonl from the spec (only if everything passes)

Environment:
  OPENGRAPH          the opengraph CLI (default /tmp/ask8/opengraph)
  OPENGRAPH_ASK_DB   the map store   (default /tmp/ask8/city.og; the default small city,
                     `opengraph sim --size small --seed 0` + `opengraph build`, commit e5afdf6)

Every query is run with --read-only. Ground plane is (x, z); y is up.

This file holds only what is set 9's own (defaults, vocabulary, questions and its reuse audit). The helpers
shared by sets 7-9 (cypher builders, running the queries, truth recomputation, the common
audits, the PASS/FAIL report) are in ../askgen.py.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))   # for ../askgen.py
from askgen import Q_ALL_SEGMENTS, Q_LANES, add, distance, near, nearest, route, run, within  # noqa: E402
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
    "tree":             r"tree|trunk|crown|canopy|foliage",
    "speed limit sign": r"speed limit|speed sign|\bsign\b",
    "pole":             r"\bpoles?\b|pylon",
    "play":             r"climbing frame|playground|play area|swings?\b|slide",
}

# ---------------------------------------------------------------- not reused from sets 7 and 8
# (from set7/gen.py and set8/gen.py)
PREV_ROUTES = {(2352, 2361), (2358, 2362), (2353, 2361), (2354, 2360), (2355, 2362), (2359, 2360),
               (2353, 2358), (2356, 2362), (2354, 2361), (2360, 2362), (2352, 2358), (2356, 2360)}
PREV_OBJECTS = {966, 167, 237, 1796, 1269, 1737, 2213, 1016, 831, 1130, 1277, 1439, 14, 836, 1897,
                1989, 1054, 64, 1073, 404, 1392, 124, 1303, 1342,                        # set 7
                2056, 1734, 892, 2016, 1053, 1274, 1764, 2215, 86, 1263, 12, 692, 1062, 1360,
                996, 2128, 495, 1276, 1915, 1776}                                        # set 8
PREV_NEAREST_ANSWERS = {1016, 990, 836, 452, 1064, 101, 1439, 203, 1737, 656, 900}
PREV_WITHIN = {("letter box", 2338), ("hatchback", 2351), ("traffic light", 2332), ("hydrant", 2345),
               ("rubbish bin", 2341), ("hatchback", 2343), ("rubbish bin", 2349), ("hatchback", 2339),
               ("letter box", 2344), ("suv", 2348), ("hydrant", 2343), ("trailer", 2350)}
PREV_REF_LABEL = {("rubbish bin", ("segment", 2346)), ("letter box", ("lane", 2357)), ("hydrant", ("start", None)),
                  ("speed limit sign", ("segment", 2332)), ("letter box", ("segment", 2343)),
                  ("hydrant", ("end", None)), ("rubbish bin", ("segment", 2347)), ("trailer", ("lane", 2353)),
                  ("letter box", ("lane", 2361)), ("hatchback", ("segment", 2351)),
                  ("trailer", ("segment", 2343)), ("rubbish bin", ("start", None)), ("letter box", ("segment", 2345)),
                  ("hydrant", ("lane", 2359)), ("letter box", ("segment", 2339)), ("trailer", ("lane", 2362))}
PREV_DIST = {(("segment", 2338), ("segment", 2351)), (("start", None), ("lane", 2357)),
             (("object", 1342), ("segment", 2335)), (("end", None), ("segment", 2342)),
             (("lane", 2356), ("lane", 2360)), (("segment", 2347), ("object", 892)), (("start", None), ("lane", 2358))}

# ---------------------------------------------------------------- the spec
# add(voice, kind, question, truth, cypher, calc, desc=..., **kw); desc entries are
#   (object id, noun key, colour|None, [attribute regexes] (each must match some caption), segment|None)

# Description shorthands (each audited to match exactly one Instance under the broad reading).
LONG_GLASS_SHELTER = (1793, "bus shelter", None, [r"\blong\b", r"glass and steel", r"timetable"], None)
YELLOW_SUV = (963, "suv", "yellow", None, None)
SMALL_BLUE_SIGN = (296, "speed limit sign", "blue", [r"\bsmall\b", r"on a post"], None)
SMALL_YELLOW_LIGHT = (428, "traffic light", "yellow", [r"\bsmall\b", r"showing green"], None)
TALL_BLACK_LIGHT = (1275, "traffic light", "black", [r"\btall\b", r"showing green"], None)
MIDSIZE_SEDAN_LANE = (200, "sedan", None, [r"mid-size", r"parking lane"], None)
LARGE_HB_CURB = (219, "hatchback", None, [r"\blarge\b", r"by the curb"], None)
SILVER_DUSTY_HB = (1019, "hatchback", "silver", [r"dusty"], None)
ROUND_RW_SIGN = (1743, "speed limit sign", "red", [r"\bround\b", r"on a post"], None)   # round red-and-white
LARGE_SUV_CURB = (1207, "suv", None, [r"\blarge\b", r"by the curb"], None)
SMALL_BIKE_STAND = (834, "bike", None, [r"\bsmall\b", r"leaning on its stand"], None)
SMALL_PLAYGROUND = (1868, "play", "red", [r"\bsmall\b", r"slide and swings"], None)   # red and yellow
NEW_CITY_BIKE = (1858, "bike", None, [r"\bnew\b", r"city bike"], None)
LARGE_WHITE_HB = (631, "hatchback", "white", [r"\blarge\b"], None)
MOTORBIKE_2338 = (13, "motorbike", None, None, 2338)
SMALL_DUSTY_SEDAN = (671, "sedan", None, [r"\bsmall\b", r"dusty"], None)
YELLOWING_2342 = (839, "tree", None, [r"yellowing"], 2342)
YELLOWING_2343 = (2089, "tree", None, [r"yellowing"], 2343)
YELLOWING_2351 = (669, "tree", None, [r"yellowing"], 2351)
DENSE_YELLOWING_2347 = (268, "tree", None, [r"dense", r"yellowing"], 2347)
SPARSE_YELLOWING_2344 = (449, "tree", None, [r"sparse", r"yellowing"], 2344)
OLD_TRUNK_2335 = (1273, "tree", None, [r"\bold\b", r"planting bed"], 2335)
OVERGROWN_HEDGE = (327, "hedge", None, [r"overgrown", r"along a garden"], None)
LARGE_PLAY_AREA = (2206, "play", None, [r"\blarge\b", r"slide and swings"], None)
CABLE_POLE = (1595, "pole", "green", [r"\bthin\b", r"cables"], None)
ROUND_BIN_LAMP = (2216, "bin", None, [r"\bround\b", r"by a lamp post"], None)
OLD_CITY_BIKE_RACK = (840, "bike", None, [r"\bold\b", r"city bike", r"locked to a rack"], None)
TRAILER_2348 = (1087, "trailer", None, None, 2348)

# ===== Voice G: retired engineer writing long, digressive emails
G = "G-retired-engineer-email"
add(G, "count", "Good afternoon. I spent thirty-one years with the Post Office engineering department before I retired, mostly on sorting machinery rather than the boxes themselves, but old habits die hard and I still notice every letter box I pass. My grandson tells me your map records them. Would you be so kind as to tell me how many letter boxes there are on the map altogether? Regards, Harold",
    {"count": 11}, q_count("letter box"), "count", label="letter box")
add(G, "count", "Dear Sir or Madam, I was a signals engineer in the days when a set of lights meant a relay cabinet, a great deal of wiring and a certain amount of swearing. Purely out of professional curiosity, and I don't need to know where any of them are, what is the total number of traffic lights on your map?",
    {"count": 18}, q_count("traffic light"), "count", label="traffic light")
within(G, "Following on from my previous note about signals. I gather that segment 2334 is one of the junctions. Back in 1978 we would have put two heads at most on a junction of that size, but I am told things have moved on considerably since then. How many traffic lights does the map place in segment 2334?",
    {"count": 4}, "traffic light", 2334)
within(G, "A neighbour of mine, who is forever writing to the paper about 'sign clutter', insists that the stretch of road you call segment 2341 is festooned with speed limit signs. I suspect he exaggerates, as he does about most things, his golf handicap included. How many speed limit signs are actually recorded in segment 2341?",
    {"count": 2}, "speed limit sign", 2341)
add(G, "count_segments", "When I was laying out junctions we used to file the full four-way crossroads together with the plain corners where the road simply turns, since neither has the awkward give-way geometry of a T. Indulge an old man: if you take the crossroads and the bends together, and leave the T-junctions out, how many such segments does the map have?",
    {"count": 7}, q_count_segments(["intersection", "l_intersection"]), "count")
add(G, "count_segments", "My late wife always said I had an unhealthy interest in T-junctions. I wrote my dissertation on sight lines at them, you see, and I have never quite shaken it off. For old times' sake, then: how many T-junctions are there on this map?",
    {"count": 2}, q_count_segments(["t_intersection"]), "count")
near(G, "I have been reading about the survey vehicle that gathered the data for your map. In my day we did this sort of thing with a theodolite, a chain and a flask of tea. Taking the spot where the vehicle began its recording run as the centre, how many traffic lights stand within 30 metres of it?",
     {"count": 4}, "traffic light", ("start", None), 30)
near(G, "Another postal question, I'm afraid. Suppose I were standing at the middle of segment 2340 with a bundle of Christmas cards; my knees being what they are, I would rather not go far. How many letter boxes lie within 70 metres of that point, measured directly rather than along the streets?",
     {"count": 4}, "letter box", ("segment", 2340), 70)
nearest(G, "I understand the survey run finished recording at a particular spot, which I gather your system knows. Out of idle curiosity, which letter box is closest to the place where the vehicle stopped recording? Its node id will do; my grandson assures me that is how your system refers to things.",
        {"id": 16}, "letter box", ("end", None))
nearest(G, "On fine days I sit in the long glass-and-steel bus shelter, the one with the timetable in it, and watch the world go by. There is nearly always a trailer parked somewhere near it, and it has started to bother me which one it is. Which trailer is nearest to that shelter? Please give me its id.",
        {"id": 1605}, "trailer", ("object", 1793), desc=[LONG_GLASS_SHELTER])
distance(G, "On a closed traverse we always checked how far the end point landed from the start; it told you a great deal about your errors. In that spirit: what is the straight-line distance, in metres, between the point where the survey vehicle started recording and the point where it finished?",
         {"distance_m": 13.3}, ("start", None), ("end", None))
distance(G, "My morning constitutional takes me from the silver hatchback with the dusty windows (somebody really ought to wash it) to the round red-and-white speed limit sign on a post at the roadside. Ignoring the streets and the corners entirely, how far apart are those two as the crow flies? Metres, please.",
         {"distance_m": 46.38}, ("object", 1019), ("object", 1743), desc=[SILVER_DUSTY_HB, ROUND_RW_SIGN])
route(G, "Here is a little problem of the sort I used to set the apprentices. A vehicle has to keep to the lanes and wants to get from lane node 2353 to lane node 2356 by the shortest possible route. How long is that route, in metres? I have worked it out on the back of an envelope and should like to check my answer.",
      {"length_m": 173.34}, 2353, 2356)
route(G, "My son-in-law drives for a living and swears that the quickest way between lane node 2354 and lane node 2357 is longer than it looks on paper. Keeping to the lane network, what is the length of the shortest route between those two nodes? In metres, please; none of this miles business.",
      {"length_m": 174.53}, 2354, 2357)
add(G, "segment", "I have taken rather a shine to the yellow SUV; it is very nearly the shade of the Land Rover I ran in the seventies, which never once started on a cold morning. Could you tell me which segment of the map it is recorded in? The segment id is all I need.",
    {"id": 2343}, q_segment(963), "segment", desc=[YELLOW_SUV])
add(G, "segment", "A small matter, but it has been nagging at me. There is a small blue speed limit sign on a post at the roadside that I walk past most days, and I have never been sure which part of the map it belongs to. In which segment is it recorded?",
    {"id": 2347}, q_segment(296), "segment", desc=[SMALL_BLUE_SIGN])
add(G, "segment_kind", "There is a small yellow traffic light showing green that I used to pass on my way to the works. I have a feeling it stands at a proper junction rather than on a plain stretch of road, but my memory is not what it was. Is it on a straight road, a bend, a T-junction or a crossroads?",
    {"kind": "crossroads"}, q_segment(428), "segment_kind", desc=[SMALL_YELLOW_LIGHT])
add(G, "segment_kind", "I wonder whether you could settle a small disagreement at the bowls club. The tall black traffic light showing green: one of us says it guards a crossroads, another says a bend. What kind of segment is it actually on: straight road, bend, T-junction or crossroads?",
    {"kind": "t_junction"}, q_segment(1275), "segment_kind", desc=[TALL_BLACK_LIGHT])
add(G, "colour", "My eyesight is not what it was, and cars all look alike to me these days. Could you tell me what colour the mid-size saloon parked in the parking lane is recorded as? I believe I have seen it outside the chemist's.",
    {"colour": "white"}, q_colour(200), "colour", desc=[MIDSIZE_SEDAN_LANE])
add(G, "colour", "One last question before my tea. The large hatchback that is always parked by the curb: I have described it to my wife as blue and she insists it is something else entirely. What colour does your map record it as?",
    {"colour": "silver"}, q_colour(219), "colour", desc=[LARGE_HB_CURB])

# ===== Voice H: teenager in a gaming-style chat, slang and abbreviations
H = "H-teen-gamer-chat"
add(H, "count", "yo how many camper vans r there on the whole map?? like the big RV looking ones lol",
    {"count": 3}, q_count("camper van"), "count", label="camper van")
add(H, "count", "ngl this map got SUVs everywhere 💀 whats the total number of SUVs on the entire map",
    {"count": 12}, q_count("suv"), "count", label="suv")
within(H, "me n the squad r tryna find scooters to ride. how many scooters r in seg 2348 rn",
       {"count": 2}, "scooter", 2348)
within(H, "lowkey need to know how many SUVs r parked in segment 2339, my mate says like 10 but hes capping fr",
       {"count": 2}, "suv", 2339)
add(H, "count_segments", "ok so in racing games the bends r the best part fr. how many bends does this map have (just corners where the road turns, no T junctions or crossroads)",
    {"count": 4}, q_count_segments(["l_intersection"]), "count")
add(H, "count_segments", "planning a speedrun route, how many junctions total on the map? crossroads, T junctions n bends all count, straight bits dont",
    {"count": 9}, q_count_segments(["intersection", "t_intersection", "l_intersection"]), "count")
near(H, "spawn point = lane node 2355 lol. how many SUVs within 60m of it??",
     {"count": 1}, "suv", ("lane", 2355), 60)
near(H, "if im camping at lane node 2352 how many hatchbacks r within 45 metres of me (straight line not driving)",
     {"count": 4}, "hatchback", ("lane", 2352), 45)
nearest(H, "which camper van is closest to the middle of seg 2345? need the id pls",
        {"id": 418}, "camper van", ("segment", 2345))
nearest(H, "bro which scooter is the nearest one to the centre of segment 2337, gimme the id",
        {"id": 1766}, "scooter", ("segment", 2337))
distance(H, "how far is it from the middle of seg 2337 to the middle of seg 2330 in a straight line? in metres, not along the roads",
         {"distance_m": 236.67}, ("segment", 2337), ("segment", 2330))
distance(H, "theres a big SUV parked by the curb (the large one). how far is it from lane node 2358 as the crow flies, in m",
         {"distance_m": 32.65}, ("object", 1207), ("lane", 2358), desc=[LARGE_SUV_CURB])
route(H, "gps q lol: shortest route from lane node 2355 to lane node 2361 following the lanes, how many metres",
      {"length_m": 136.01}, 2355, 2361)
route(H, "race from lane node 2361 to lane node 2362, shortest path on the lanes only, no cutting corners. how long is it in m??",
      {"length_m": 307.17}, 2361, 2362)
add(H, "segment", "wheres that small bike leaning on its stand? which segment is it in, need the seg id",
    {"id": 2342}, q_segment(834), "segment", desc=[SMALL_BIKE_STAND])
add(H, "segment", "the lil red and yellow playground with the slide n swings, whats the segment id for it",
    {"id": 2349}, q_segment(1868), "segment", desc=[SMALL_PLAYGROUND])
add(H, "segment_kind", "that new city bike, is it on a straight road, a bend, a T junction or a crossroads? asking for a friend 😂",
    {"kind": "straight_road"}, q_segment(1858), "segment_kind", desc=[NEW_CITY_BIKE])
add(H, "segment_kind", "big white hatchback (the large one) - what kinda road is it on? straight, bend, T junction or crossroads",
    {"kind": "straight_road"}, q_segment(631), "segment_kind", desc=[LARGE_WHITE_HB])
add(H, "colour", "whats the colour of the motorbike in seg 2338? tryna see if it matches my skin in the game lol",
    {"colour": "silver"}, q_colour(13), "colour", desc=[MOTORBIKE_2338])
add(H, "colour", "the small sedan w/ the dusty windows... what colour is it actually",
    {"colour": "white"}, q_colour(671), "colour", desc=[SMALL_DUSTY_SEDAN])

# ===== Voice I: city tree surveyor / ecologist, field-notes shorthand
I = "I-tree-surveyor-notes"
add(I, "count", "Street-furniture inventory, whole map. Litter bins (all types): total n = ?",
    {"count": 19}, q_count("rubbish bin"), "count", label="rubbish bin")
add(I, "count", "Sightline survey - speed limit signs often obscured by canopy. Total no. of speed limit signs on the map?",
    {"count": 7}, q_count("speed limit sign"), "count", label="speed limit sign")
within(I, "Plot: seg 2346. Litter bins recorded inside the plot - count? (root-zone compaction notes)",
       {"count": 2}, "rubbish bin", 2346)
within(I, "Tree-pit planning, seg 2344. Hydrants present in this segment: how many? (need clearance)",
       {"count": 0}, "hydrant", 2344, segment_must_exist=2344)
add(I, "count_segments", "Transect design. Straight road segments on the map, excl. all junctions: how many in total?",
    {"count": 14}, q_count_segments(["straight_roadway"]), "count")
add(I, "count_segments", "Sampling frame = every road segment on the map, any type. N segments = ?",
    {"count": 23}, Q_ALL_SEGMENTS, "count")
near(I, "Ref. tree: yellowing crown in seg 2342 (poss. drought stress). Litter bins w/in 55 m radius of it - count?",
     {"count": 2}, "rubbish bin", ("object", 839), 55, desc=[YELLOWING_2342])
near(I, "Overgrown hedge along a garden, flagged for cutting back. Hydrants within 30 m of it, straight line: how many?",
     {"count": 1}, "hydrant", ("object", 327), 30, desc=[OVERGROWN_HEDGE])
nearest(I, "Stn 4: yellowing crown, seg 2343. Nearest litter bin to that tree? Record id.",
        {"id": 960}, "rubbish bin", ("object", 2089), desc=[YELLOWING_2343])
nearest(I, "Dense yellowing canopy in seg 2347, may be blocking a signal head. Which traffic light is closest to it? id pls.",
        {"id": 271}, "traffic light", ("object", 268), desc=[DENSE_YELLOWING_2347])
distance(I, "Dist. between the old trunk in the small planting bed (seg 2335) and the sparse yellowing canopy (seg 2344), straight line, m?",
         {"distance_m": 89.57}, ("object", 1273), ("object", 449), desc=[OLD_TRUNK_2335, SPARSE_YELLOWING_2344])
distance(I, "Yellowing crown in seg 2351 -> lane node 2362: straight-line dist. in m?",
         {"distance_m": 42.45}, ("object", 669), ("lane", 2362), desc=[YELLOWING_2351])
route(I, "Access for the chipper (must keep to lanes). Shortest lane route lane node 2353 to lane node 2359, length in m?",
      {"length_m": 187.47}, 2353, 2359)
route(I, "Watering bowser run: lane node 2352 -> lane node 2360 via the lanes, shortest. Total m?",
      {"length_m": 264.85}, 2352, 2360)
add(I, "segment", "Overgrown hedge along a garden: which segment? Need seg id for the cutting schedule.",
    {"id": 2340}, q_segment(327), "segment", desc=[OVERGROWN_HEDGE])
add(I, "segment", "Large children's play area w/ slide & swings (next to survey trees). Seg id?",
    {"id": 2338}, q_segment(2206), "segment", desc=[LARGE_PLAY_AREA])
add(I, "segment_kind", "Thin green utility pole carrying cables - line-clearance check. Segment type: straight road / bend / T-junction / crossroads?",
    {"kind": "t_junction"}, q_segment(1595), "segment_kind", desc=[CABLE_POLE])
add(I, "segment_kind", "Round litter bin by a lamp post. Type of road segment it sits on (straight, bend, T-jn, crossroads)?",
    {"kind": "straight_road"}, q_segment(2216), "segment_kind", desc=[ROUND_BIN_LAMP])
add(I, "colour", "Old city bike locked to a rack, chained up next to a tree pit. Colour as recorded?",
    {"colour": "grey"}, q_colour(840), "colour", desc=[OLD_CITY_BIKE_RACK])
add(I, "colour", "Trailer parked in seg 2348 under the street trees. Colour? (for photo ref)",
    {"colour": "silver"}, q_colour(1087), "colour", desc=[TRAILER_2348])

# ---------------------------------------------------------------- set 9's own audits
def reuse_audit(q, lane_adj, probs):
    """Nothing that sets 7 and 8 asked about is asked again (see PREV_* above)."""
    for (oid, *_rest) in q["desc"]:
        if oid in PREV_OBJECTS:
            probs.append(f"object {oid} was already named in set 7 or 8")
    if q["calc"] == "route":
        pair = tuple(sorted((q["src"], q["dst"])))
        if pair in PREV_ROUTES:
            probs.append(f"route pair {pair} already used in set 7 or 8")
        if pair in lane_adj:
            probs.append(f"route pair {pair} is a single LANE edge")
    if q["kind"] == "count_within" and (q["label"], q["seg"]) in PREV_WITHIN:
        probs.append(f"count_within ({q['label']}, {q['seg']}) already used in set 7 or 8")
    if q["kind"] in ("count_near", "nearest"):
        if (q["label"], tuple(q["ref"])) in PREV_REF_LABEL:
            probs.append(f"({q['label']}, {q['ref']}) already used in set 7 or 8")
        if q["ref"][0] == "object" and q["ref"][1] in PREV_OBJECTS:
            probs.append(f"reference object {q['ref'][1]} already named in set 7 or 8")
    if q["kind"] == "nearest":
        ans = q["truth"]["id"]
        if ans in PREV_NEAREST_ANSWERS or ans in PREV_OBJECTS:
            probs.append(f"nearest answer {ans} already an answer or target in set 7 or 8")
    if q["kind"] == "distance":
        a, b = (tuple(x) for x in q["pair"])
        if (a, b) in PREV_DIST or (b, a) in PREV_DIST:
            probs.append(f"distance pair {a}-{b} already used in set 7 or 8")
        for r in (a, b):
            if r[0] == "object" and r[1] in PREV_OBJECTS:
                probs.append(f"object {r[1]} already named in set 7 or 8")

def prepare():
    """Set 9's per-question audit: no reuse of sets 7-8, no single-edge route, no repeated text."""
    lane_adj = {tuple(sorted((r["a"], r["b"]))) for r in run(Q_LANES)}
    previous = askgen.other_set_questions(HERE)
    def audit(q, probs):
        reuse_audit(q, lane_adj, probs)
        if q["question"].strip().lower() in previous:
            probs.append("question text already used in another set")
    return audit

def main():
    check(here=HERE, og_default=OG_DEFAULT, db_default=DB_DEFAULT, kinds=KINDS, nouns=NOUNS,
          prepare=prepare, pass_note=", no reuse of sets 7-8")

if __name__ == "__main__":
    main()
