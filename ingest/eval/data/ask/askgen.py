"""Shared helpers of the set 7 to 10 generators (`setN/gen.py`).

Each `setN/gen.py` keeps only what is its own: the defaults for `$OPENGRAPH` and
`$OPENGRAPH_ASK_DB`, its vocabulary (`KINDS`, `NOUNS`), its questions (`add` and the shorthands
below) and any audit of its own. This module has the rest: the cypher builders, running
`opengraph query --read-only --json`, the truth recomputation (ground-plane distances,
Dijkstra over the `LANE` edges), the audits shared by all three sets, and the check against
`questions.jsonl` with its `RESULT: PASS` / `RESULT: FAIL` report (`main`).

Every query is run with --read-only. Ground plane is (x, z); y is up.
"""
import glob
import heapq
import json
import math
import os
import re
import subprocess
import sys
from collections import Counter, defaultdict

KIND_MAP = {"intersection": "crossroads", "t_intersection": "t_junction",
            "l_intersection": "bend", "straight_roadway": "straight_road"}
NEAR_MARGIN_M = 1.0      # count_near: no object of the kind within this of the radius
NEAREST_GAP_M = 0.5      # nearest: second nearest at least this much farther
ROUTE_GAP_M = 10.0       # route_length: second-best simple path at least this much longer

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
    # Set 9's version: sets 7 and 8 dropped the first point's variable at the second WITH when
    # the second point is a Frame. Their questions never have a Frame second, so their
    # cyphers are the same under either version.
    ma, xa, za = ref_match(a)
    mb, xb, zb = ref_match(b)
    keep = "f" if a[0] in ("start", "end") else "p"       # the first point's variable survives WITH
    mb = (mb.replace("(p:", "(q:").replace("id(p)", "id(q)").replace("(f:", "(g:")
            .replace("WITH f ORDER BY f.index", f"WITH {keep}, g ORDER BY g.index"))
    xb = xb.replace("p.", "q.").replace("f.", "g."); zb = zb.replace("p.", "q.").replace("f.", "g.")
    return f"{ma} {mb} RETURN sqrt(({xa} - {xb})^2 + ({za} - {zb})^2) AS d"

Q_LANES = "MATCH (a:LaneNode)-[r:LANE]->(b:LaneNode) RETURN id(a) AS a, id(b) AS b, r.length_m AS len"
Q_ALL_SEGMENTS = "MATCH (s:Segment) RETURN count(s) AS count"

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

# Shorthands (set 9's); they keep ref / pair / seg on the question for audits that need them.
def near(voice, question, truth, label, ref, radius, desc=()):
    add(voice, "count_near", question, truth, q_distances(label, ref), "near_count",
        desc=desc, radius=radius, label=label, ref=ref)

def nearest(voice, question, truth, label, ref, desc=()):
    add(voice, "nearest", question, truth, q_distances(label, ref), "nearest", desc=desc, label=label, ref=ref)

def distance(voice, question, truth, a, b, desc=()):
    add(voice, "distance", question, truth, q_pair(a, b), "distance", desc=desc, pair=(a, b))

def route(voice, question, truth, src, dst):
    add(voice, "route_length", question, truth, Q_LANES, "route", src=src, dst=dst)

def within(voice, question, truth, label, seg, **kw):
    add(voice, "count_within", question, truth, q_count_within(label, seg), "count", label=label, seg=seg, **kw)

# ---------------------------------------------------------------- running
OG = None   # the opengraph CLI and the map store; set by main() from the environment
DB = None
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

def compute(q, problems, ref_point_guard=True):
    rows = run(q["cypher"]); c = q["calc"]
    if c == "count":
        return {"count": rows[0]["count"]}
    if ref_point_guard and c in ("near_count", "nearest") and any(r["d"] < 1e-9 for r in rows):
        problems.append("an object of the kind sits at the reference point itself")
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

def desc_matches(objs, nouns, noun, colour, attrs, segment):
    out = []
    for o in objs:
        if not names(o, nouns[noun]):
            continue
        if colour and not names_colour(o, colour):
            continue
        if attrs and not all(any(re.search(a, c, re.I) for c in (o["captions"] or [])) for a in attrs):
            continue
        if segment is not None and segment not in o["segs"]:
            continue
        out.append(o["id"])
    return out

def label_audit(objs, kinds, label, problems):
    rx = re.compile(kinds[label], re.I)
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

# ---------------------------------------------------------------- check and report
def other_set_questions(here):
    """Question texts, lower-cased, of every set but the one in folder `here`
    (../set*/questions.jsonl beside it; for the exact-duplicate check)."""
    out = set()
    for path in glob.glob(os.path.join(here, "..", "set*", "questions.jsonl")):
        if os.path.abspath(os.path.dirname(path)) == here:
            continue
        for line in open(path):
            if line.strip():
                out.add(json.loads(line)["question"].strip().lower())
    return out



# ---------------------------------------------------------------- reuse audits of sets 10 and on
# Reference points in a cypher built by ref_match, and a segment's kind asked by its id.
REF_RX = [
    (re.compile(r"\((?:p|q):Segment\) WHERE id\((?:p|q)\) = (\d+)"), "segment"),
    (re.compile(r"\((?:p|q):LaneNode\) WHERE id\((?:p|q)\) = (\d+)"), "lane"),
    (re.compile(r"\((?:p|q):Instance\) WHERE id\((?:p|q)\) = (\d+)"), "object"),
]
SEG_KIND_BY_ID = re.compile(r"^MATCH \(s:Segment\) WHERE id\(s\) = (\d+) RETURN id\(s\) AS id, s\.kind AS kind$")


def refs_in(cypher):
    """Reference points of a cypher built by ref_match, in order of appearance."""
    out = []
    for rx, t in REF_RX:
        for mm in rx.finditer(cypher):
            out.append((mm.start(), (t, int(mm.group(1)))))
    for mm in re.finditer(r"\((?:f|g):Frame\)[^A-Z]*WITH [^O]*ORDER BY (?:f|g)\.index (ASC|DESC)", cypher):
        out.append((mm.start(), ("start" if mm.group(1) == "ASC" else "end", None)))
    return [r for _, r in sorted(out)]


def prev_from_files(here, sets):
    """What the sets named in `sets` (folders beside `here`) used, re-derived from the cyphers and
    truths of their questions.jsonl: objects named, nearest answers, count_within pairs, (label,
    reference) pairs, distance pairs and segments whose kind was asked by id."""
    P = dict(objects=set(), answers=set(), within=set(), reflabel=set(), dist=set(), segkind=set())
    for s in sets:
        for line in open(os.path.join(here, "..", s, "questions.jsonl")):
            if not line.strip():
                continue
            q = json.loads(line); c = q["cypher"]; k = q["kind"]
            lab = re.search(r"\{label: '([^']+)'\}", c)
            P["objects"].update(int(x) for x in re.findall(r"WHERE id\(n\) = (\d+)", c))
            rs = refs_in(c)
            P["objects"].update(r[1] for r in rs if r[0] == "object")
            if k == "nearest":
                P["answers"].add(q["truth"]["id"])
            if k == "count_within":
                P["within"].add((lab.group(1), int(re.search(r"id\(s\) = (\d+)", c).group(1))))
            if k in ("count_near", "nearest"):
                P["reflabel"].add((lab.group(1), rs[0]))
            if k == "distance":
                P["dist"].add(tuple(rs))
            m = SEG_KIND_BY_ID.match(c)
            if k == "segment_kind" and m:
                P["segkind"].add(int(m.group(1)))
    return P


def run_aside(cypher):
    """run() for an audit's own lookups, kept out of the cache that the PASS line counts."""
    cached = cypher in _cache
    rows = run(cypher)
    if not cached:
        del _cache[cypher]
    return rows


def ref_points():
    """Ground-plane (x, z) of every reference a question can name: ("segment", id), ("lane", id),
    ("object", id), and the drive's ("start", None) and ("end", None)."""
    pts = {}
    for r in run_aside("MATCH (s:Segment) RETURN id(s) AS id, s.centroid.x AS x, s.centroid.z AS z"):
        pts[("segment", r["id"])] = (r["x"], r["z"])
    for r in run_aside("MATCH (p:LaneNode) RETURN id(p) AS id, p.position.x AS x, p.position.z AS z"):
        pts[("lane", r["id"])] = (r["x"], r["z"])
    for r in run_aside("MATCH (n:Instance) RETURN id(n) AS id, n.centroid.x AS x, n.centroid.z AS z"):
        pts[("object", r["id"])] = (r["x"], r["z"])
    fr = run_aside("MATCH (f:Frame) RETURN f.index AS i, f.world_from_velo[3] AS x, f.world_from_velo[11] AS z ORDER BY f.index")
    pts[("start", None)] = (fr[0]["x"], fr[0]["z"]); pts[("end", None)] = (fr[-1]["x"], fr[-1]["z"])
    return pts

def main(*, here, og_default, db_default, kinds, nouns, extra_guards=True, prepare=None, pass_note=""):
    """Re-run every cypher of S, recompute the truths, run the audits and compare with
    here/questions.jsonl (rewritten first with --write, only if everything passes).

    kinds / nouns: the set's vocabulary (label -> regex, description noun -> regex).
    extra_guards: set 8's two guards (every Segment kind is one of KIND_MAP's; no object of the
      counted kind at the reference point of a count_near or nearest); set 7 was written without.
    prepare: called once the store is set, returns a per-question audit f(q, problems).
    pass_note: appended to the list of audits in the PASS line.
    """
    global OG, DB
    OG = os.environ.get("OPENGRAPH", og_default)
    DB = os.environ.get("OPENGRAPH_ASK_DB", db_default)
    out = os.path.join(here, "questions.jsonl")
    write = "--write" in sys.argv
    objs = run(Q_ALL)
    segs = run(Q_SEGS)
    seg_ids = {r["id"] for r in segs}
    fails = []
    if extra_guards:
        odd = sorted({r["kind"] for r in segs} - set(KIND_MAP))
        if odd:
            fails.append(f"segment kinds outside the four used in questions: {odd}")
    multi = [o["id"] for o in objs if len(o["segs"]) != 1]
    if multi:
        fails.append(f"objects not in exactly one segment: {multi[:10]}")
    label_totals = {}
    for lab in kinds:
        probs = []
        label_totals[lab] = label_audit(objs, kinds, lab, probs)
        fails += probs
    own_audit = prepare() if prepare else None
    kind_n = Counter(); voices = Counter(); vk = Counter()
    for i, q in enumerate(S, 1):
        probs = []
        got = compute(q, probs, ref_point_guard=extra_guards)
        if got != q["truth"]:
            probs.append(f"truth mismatch: spec {q['truth']} vs recomputed {got}")
        for (oid, noun, colour, attrs, segment) in q["desc"]:
            m = desc_matches(objs, nouns, noun, colour, attrs, segment)
            if m != [oid]:
                probs.append(f"description ({noun}, {colour}, {attrs}, seg {segment}) matches {m}, expected [{oid}]")
        if q.get("label") and q["label"] not in kinds:
            probs.append(f"label {q['label']} not audited")
        # a count over a segment id that does not exist would silently give 0
        for m in re.finditer(r"id\(s\) = (\d+)", q["cypher"]):
            if int(m.group(1)) not in seg_ids:
                probs.append(f"segment {m.group(1)} does not exist")
        if own_audit:
            own_audit(q, probs)
        for p in probs:
            fails.append(f"Q{i:02d} [{q['kind']}] {p}")
        kind_n[q["kind"]] += 1; voices[q["voice"]] += 1; vk[(q["voice"], q["kind"])] += 1
    if len(S) != 60 or any(v != 6 for v in kind_n.values()) or len(kind_n) != 10:
        fails.append(f"kind distribution wrong: {dict(kind_n)}")
    if any(v != 20 for v in voices.values()) or len(voices) != 3 or any(v != 2 for v in vk.values()):
        fails.append(f"voice distribution wrong: {dict(voices)}")
    if len({q['question'] for q in S}) != len(S):
        fails.append("duplicate question text")
    records = [{"kind": q["kind"], "question": q["question"], "truth": q["truth"], "cypher": q["cypher"]} for q in S]
    if write and not fails:
        with open(out, "w") as f:
            for r in records:
                f.write(json.dumps(r, ensure_ascii=False) + "\n")
    if os.path.exists(out):
        disk = [json.loads(line) for line in open(out) if line.strip()]
        if disk != records:
            fails.append("questions.jsonl differs from the spec (run with --write)")
    else:
        fails.append("questions.jsonl missing (run with --write)")
    print("label totals:", json.dumps(label_totals))
    print("per kind:", json.dumps(dict(sorted(kind_n.items()))), "per voice:", json.dumps(dict(sorted(voices.items()))))
    for f in fails:
        print("FAIL:", f)
    if fails:
        print(f"RESULT: FAIL ({len(fails)} problem(s)) over {len(S)} questions")
        sys.exit(1)
    print(f"RESULT: PASS - {len(S)} questions, truths recomputed from {len(_cache) - 2} distinct cypher statements, "
          f"all audits (labels, descriptions, radius margins >= {NEAR_MARGIN_M} m, nearest gaps >= {NEAREST_GAP_M} m, "
          f"route gaps >= {ROUTE_GAP_M} m, colours, segment ids{pass_note}) ok")
