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

This file holds only what is set 8's own (defaults, vocabulary, questions). The helpers
shared by sets 7-9 (cypher builders, running the queries, truth recomputation, the common
audits, the PASS/FAIL report) are in ../askgen.py.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))   # for ../askgen.py
from askgen import Q_ALL_SEGMENTS, Q_LANES, add, q_colour, q_count, q_count_segments  # noqa: E402
from askgen import q_count_within, q_distances, q_pair, q_segment, main as check  # noqa: E402

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

# ---------------------------------------------------------------- the spec
# add(voice, kind, question, truth, cypher, calc, desc=..., **kw); desc entries are
#   (object id, noun key, colour|None, [attribute regexes] (each must match some caption), segment|None)

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

def main():
    check(here=HERE, og_default=OG_DEFAULT, db_default=DB_DEFAULT, kinds=KINDS, nouns=NOUNS)

if __name__ == "__main__":
    main()
