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

This file holds only what is set 7's own (defaults, vocabulary, questions). The helpers
shared by sets 7-9 (cypher builders, running the queries, truth recomputation, the common
audits, the PASS/FAIL report) are in ../askgen.py.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))   # for ../askgen.py
from askgen import Q_LANES, add, q_colour, q_count, q_count_segments, q_count_within  # noqa: E402
from askgen import q_distances, q_pair, q_segment, main as check  # noqa: E402

OG_DEFAULT = "/tmp/ask7/opengraph"   # $OPENGRAPH
DB_DEFAULT = "/tmp/ask7/city.og"     # $OPENGRAPH_ASK_DB

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

# ---------------------------------------------------------------- the spec
# add(voice, kind, question, truth, cypher, calc, desc=..., **kw); desc entries are
#   (object id, noun key, colour|None, [attribute regexes] (each must match some caption), segment|None)

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

def main():
    # set 7 was written before set 8 added its two guards (see askgen.main), so they stay off here
    check(here=HERE, og_default=OG_DEFAULT, db_default=DB_DEFAULT, kinds=KINDS, nouns=NOUNS, extra_guards=False)

if __name__ == "__main__":
    main()
