"""Loads each of a map's exports with its consumer's own library and checks it against the
map's node-link export (the store's every node and relationship).

usage: check_exports.py DIR
DIR holds map.json (node-link), map.graphml, map.geojson, map.dsg.json (Spark-DSG),
map_class.ply, map_instance.ply and csv/ (Neo4j bulk-import files), and answers.json (what
`opengraph export --json` said for each). Prints one JSON line of measured counts; exits 1
with the failed check's message.
"""

import csv
import json
import math
import os
import sys
import tempfile

import kuzu
import networkx as nx
import numpy as np
import plyfile
import shapely
import spark_dsg
from shapely.geometry import Point, shape

d = sys.argv[1]
answers = json.load(open(os.path.join(d, "answers.json")))
out = {}


def check(cond, msg):
    if not cond:
        print(f"check failed: {msg}", file=sys.stderr)
        sys.exit(1)


# --- the map itself, from node-link -------------------------------------------------------
nl = json.load(open(os.path.join(d, "map.json")))
nodes = {n["id"]: n for n in nl["nodes"]}
by_label = {}
for n in nl["nodes"]:
    for label in n["labels"]:
        by_label.setdefault(label, []).append(n)
rels = nl["edges"]
env = by_label["Environment"][0]
frame = env["ground_frame"]
check(frame in ("kitti_cam", "enu"), f"ground frame {frame}")


def ground(p):
    return (p["x"], p["z"]) if frame == "kitti_cam" else (p["x"], p["y"])


def height(p):
    return -p["y"] if frame == "kitti_cam" else p["z"]


# --- networkx reads node-link and GraphML -------------------------------------------------
g = nx.node_link_graph(nl, edges="edges")
check(g.number_of_nodes() == answers["node-link"]["nodes"], "node-link node count")
check(g.number_of_edges() == answers["node-link"]["relationships"], "node-link edge count")
gm = nx.read_graphml(os.path.join(d, "map.graphml"))
check(gm.number_of_nodes() == g.number_of_nodes(), "GraphML node count")
check(gm.number_of_edges() == g.number_of_edges(), "GraphML edge count")
out["networkx"] = {"nodes": g.number_of_nodes(), "edges": g.number_of_edges()}

# --- Neo4j bulk-import CSV: the documented header format, then loaded into Kùzu ------------
csv_dir = os.path.join(d, "csv")
files = sorted(f for f in os.listdir(csv_dir) if f.endswith(".csv"))
check(answers["neo4j-csv"]["files"][:-1] == files, "the answer lists the CSV files")
TYPES = {"boolean", "long", "double", "string", "point", "float[]", "long[]", "double[]", "string[]"}
KUZU = {"boolean": "BOOLEAN", "long": "INT64", "double": "DOUBLE"}
db_dir = tempfile.mkdtemp()
conn = kuzu.Connection(kuzu.Database(os.path.join(db_dir, "k")))
table_of_file = {}
node_rows = 0
for f in files:
    if not f.startswith("nodes"):
        continue
    with open(os.path.join(csv_dir, f), newline="") as fh:
        rows = list(csv.reader(fh))
    header = rows[0]
    check(header[0] == ":ID" and header[-1] == ":LABEL", f"{f}: header {header}")
    cols = []
    for h in header[1:-1]:
        name, _, ty = h.rpartition(":")
        check(name and ty in TYPES, f"{f}: column {h!r} is not name:type")
        cols.append((name, ty))
    labels = {r[-1] for r in rows[1:]}
    check(len(labels) == 1, f"{f}: one label set per file ({labels})")
    table = f[: -len(".csv")]
    table_of_file[table[len("nodes_"):]] = table
    ddl = ", ".join(["id INT64"] + [f"`{n}` {KUZU.get(t, 'STRING')}" for n, t in cols] + ["lbl STRING"])
    conn.execute(f"CREATE NODE TABLE {table}({ddl}, PRIMARY KEY(id))")
    conn.execute(f"COPY {table} FROM '{os.path.join(csv_dir, f)}' (header=true)")
    node_rows += len(rows) - 1
rel_rows = 0
for f in files:
    if not f.startswith("relationships"):
        continue
    with open(os.path.join(csv_dir, f), newline="") as fh:
        rows = list(csv.reader(fh))
    header = rows[0]
    check(header[:3] == [":START_ID", ":END_ID", ":TYPE"], f"{f}: header {header}")
    cols = []
    for h in header[3:]:
        name, _, ty = h.rpartition(":")
        check(name and ty in TYPES, f"{f}: column {h!r} is not name:type")
        cols.append((name, ty))
    types = {r[2] for r in rows[1:]}
    check(len(types) == 1, f"{f}: one type per file")
    # relationships_<TYPE>_<start>_<end>.csv, the ends being node files' label parts
    rest = f[len("relationships_"): -len(".csv")]
    ty = types.pop()
    check(rest.startswith(ty + "_"), f"{f}: named by its type {ty}")
    ends = rest[len(ty) + 1:]
    pair = [(a, b) for a in table_of_file for b in table_of_file if f"{a}_{b}" == ends]
    check(len(pair) == 1, f"{f}: its two node files ({ends})")
    a, b = pair[0]
    table = "r_" + rest
    ddl = ", ".join([f"FROM {table_of_file[a]} TO {table_of_file[b]}", "typ STRING"]
                    + [f"`{n}` {KUZU.get(t, 'STRING')}" for n, t in cols])
    conn.execute(f"CREATE REL TABLE {table}({ddl})")
    conn.execute(f"COPY {table} FROM '{os.path.join(csv_dir, f)}' (header=true)")
    rel_rows += len(rows) - 1
kn = conn.execute("MATCH (n) RETURN count(n)").get_next()[0]
kr = conn.execute("MATCH ()-[r]->() RETURN count(r)").get_next()[0]
check(kn == len(nl["nodes"]) == node_rows, f"Kùzu nodes {kn} vs the map's {len(nl['nodes'])}")
check(kr == len(rels) == rel_rows, f"Kùzu relationships {kr} vs the map's {len(rels)}")
# a typed column comes back as numbers: the instances' point counts
if "nodes_Instance" in table_of_file.values():
    total = conn.execute("MATCH (n:nodes_Instance) RETURN sum(n.point_count)").get_next()[0]
    want = sum(n.get("point_count", 0) for n in by_label["Instance"])
    check(total == want, f"Kùzu sum(point_count) {total} vs {want}")
out["kuzu"] = {"nodes": kn, "relationships": kr}

# --- Spark-DSG: layers, positions, edges --------------------------------------------------
G = spark_dsg.DynamicSceneGraph.load(os.path.join(d, "map.dsg.json"))
layers = {2: "Instance", 3: "LaneNode", 4: "Segment", 5: "Environment"}
for layer, label in layers.items():
    n = G.get_layer(layer).num_nodes()
    check(n == len(by_label.get(label, [])), f"Spark-DSG layer {layer}: {n} nodes, map {label}: {len(by_label.get(label, []))}")
worst = 0.0
for n in by_label["Instance"]:
    node = G.get_node(spark_dsg.NodeSymbol("O", n["id"]).value)
    p = node.attributes.position
    c = n["centroid"]
    want = (*ground(c), height(c))
    worst = max(worst, max(abs(float(p[i]) - want[i]) for i in range(3)))
    # an object's name is what it is: its label, else its SemanticKITTI class
    check(node.attributes.name == (n.get("label") or n["semantic_class"]),
          f"Spark-DSG object {n['id']} is named {node.attributes.name!r}, not its label")
check(worst < 1e-6, f"Spark-DSG object positions off by {worst}")
# IN_SEGMENT makes the segment an instance's parent
segs_of = {r["source"]: r["target"] for r in rels if r["type"] == "IN_SEGMENT"}
for n in by_label["Instance"]:
    if n["id"] in segs_of:
        node = G.get_node(spark_dsg.NodeSymbol("O", n["id"]).value)
        check(node.has_parent() and node.get_parent() == spark_dsg.NodeSymbol("R", segs_of[n["id"]]).value,
              f"instance {n['id']}'s parent is its segment")
pairs = {frozenset((r["source"], r["target"])) for r in rels
         if r["type"] in ("LANE", "CONNECTS", "RELATED", "IN_SEGMENT", "CONTAINS") and r["source"] != r["target"]}
check(G.num_edges() == len(pairs) == answers["spark-dsg"]["relationships"],
      f"Spark-DSG edges {G.num_edges()} vs the map's {len(pairs)} node pairs")
out["spark_dsg"] = {"nodes": G.num_nodes(), "edges": G.num_edges(), "objects": G.get_layer(2).num_nodes()}

# --- GeoJSON with shapely: areas and containment ------------------------------------------
gj = json.load(open(os.path.join(d, "map.geojson")))
check(gj["type"] == "FeatureCollection" and "not longitude" in gj["opengraph_frame"], "GeoJSON frame stated")
feats = {}
for f in gj["features"]:
    feats.setdefault(f["properties"]["layer"], []).append(f)
segments = {f["properties"]["id"]: shape(f["geometry"]) for f in feats.get("segment", [])}
out["segment_kinds"] = sorted({f["geometry"]["type"] for f in feats.get("segment", [])})
drivable = {f["properties"]["id"]: (shape(f["geometry"]), f["properties"]["area_m2"]) for f in feats.get("drivable", [])}
check(len(segments) == len(by_label["Segment"]), "a polygon per segment")
for f in feats["segment"]:
    s = segments[f["properties"]["id"]]
    check(s.is_valid, f"segment {f['properties']['id']} polygon is valid")
    r = f["properties"].get("disc_radius_m")
    if r is not None:
        check(math.pi * r * r <= s.area <= math.pi * r * r * 1.005, f"disc area {s.area} for radius {r}")
for sid, (mp, area_m2) in drivable.items():
    check(mp.is_valid, f"segment {sid}'s drivable area is valid")
    if area_m2:
        check(abs(mp.area - area_m2) <= 0.01 * area_m2, f"drivable area {mp.area} vs Segment.drivable_area_m2 {area_m2}")
dist_of = {r["source"]: (r["target"], r.get("distance_m", None)) for r in rels if r["type"] == "IN_SEGMENT"}
inside = 0
for n in by_label["Instance"]:
    seg, dm = dist_of.get(n["id"], (None, None))
    if seg is None or dm is None or dm > 0:
        continue
    lo, hi = n["bbox"]
    c = Point(*(0.5 * (a + b) for a, b in zip(ground(lo), ground(hi))))
    # a measured drivable area's rings are the map's own; a corridor's round ends and joins
    # are polygons within a few centimetres of the circle
    area, tol = (drivable[seg][0], 1e-6) if seg in drivable else (segments[seg], 0.05)
    check(area.buffer(tol).contains(c), f"instance {n['id']} (IN_SEGMENT distance 0) lies in segment {seg}'s area")
    inside += 1
check(inside > 0, "some instance lies in its segment")
foot = {f["properties"]["id"]: shape(f["geometry"]) for f in feats["instance"]}
check(len(foot) == len(by_label["Instance"]), "a footprint per instance")
for n in by_label["Instance"]:
    check(foot[n["id"]].buffer(1e-6).contains(Point(*ground(n["centroid"]))), f"instance {n['id']}'s footprint holds its centroid")
props_of = {f["properties"]["id"]: f["properties"] for f in feats["instance"]}
check(all(props_of[n["id"]]["label"] == n.get("label") and props_of[n["id"]]["semantic_class"] == n["semantic_class"]
          for n in by_label["Instance"]), "GeoJSON instances carry label and semantic_class")
out["geojson"] = {k: len(v) for k, v in sorted(feats.items())}
out["geojson"]["instances_in_their_segment"] = inside

# --- PLY with plyfile ---------------------------------------------------------------------
for colouring in ("class", "instance"):
    ply = plyfile.PlyData.read(os.path.join(d, f"map_{colouring}.ply"))
    v = ply["vertex"].data
    check(len(v) == answers[f"ply-{colouring}"]["points"], f"PLY {colouring}: {len(v)} vertices")
    for c in ("x", "y", "z"):
        check(v[c].dtype == np.float32, f"PLY {c} is float32")
    check(any("frame:" in c for c in ply.comments), "PLY frame comment")
    nodes_in = np.unique(v["node"])
    colour_of = {}
    for nid in nodes_in:
        sel = v[v["node"] == nid]
        cols = {(int(a), int(b), int(c)) for a, b, c in zip(sel["red"], sel["green"], sel["blue"])}
        check(len(cols) == 1, f"PLY {colouring}: one colour per instance")
        colour_of[int(nid)] = cols.pop()
        inst = nodes[int(nid)]
        if "point_count" in inst:
            check(len(sel) == inst["point_count"], f"instance {nid}: {len(sel)} points vs point_count {inst['point_count']}")
        lo, hi = inst["bbox"]
        xyz = np.stack([sel["x"], sel["y"], sel["z"]], axis=1)
        lo_a = np.array([lo["x"], lo["y"], lo["z"]]) - 0.01
        hi_a = np.array([hi["x"], hi["y"], hi["z"]]) + 0.01
        check(bool(((xyz >= lo_a) & (xyz <= hi_a)).all()), f"instance {nid}'s points lie in its box")
    if colouring == "class":
        by_class = {}
        for nid, col in colour_of.items():
            by_class.setdefault(nodes[nid]["semantic_class"], set()).add(col)
        check(all(len(c) == 1 for c in by_class.values()), "one colour per class")
        firsts = [next(iter(c)) for c in by_class.values()]
        check(len(set(firsts)) == len(firsts), "different classes, different colours")
    out[f"ply_{colouring}"] = {"points": len(v), "instances": len(nodes_in)}

print(json.dumps(out, sort_keys=True))
