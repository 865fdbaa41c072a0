"""The `opengraph` package on real maps: every Map method, every exception class, numpy
dtypes and shapes, threads, exports, `sim` and `build` with progress, and an answer compared
with the HTTP API's for the same request.

Environment (set by api/tests/python_package.rs, which builds the maps and installs the wheel):
    OPENGRAPH_TEST_DIR   a scratch folder
    OPENGRAPH_TEST_MAP   a simulated city's map (hash embedder)
    OPENGRAPH_TEST_SIM   its simulated sequence
    OPENGRAPH_TEST_KITTI_MAP  the KITTI sample's oracle map (skipped when absent)
    OPENGRAPH_BIN        the opengraph binary, for the HTTP comparison
"""

import json
import os
import pathlib
import shutil
import subprocess
import threading
import time
import urllib.request

import numpy as np
import pytest

import opengraph

MAP = os.environ["OPENGRAPH_TEST_MAP"]
SIM = os.environ["OPENGRAPH_TEST_SIM"]
SCRATCH = pathlib.Path(os.environ["OPENGRAPH_TEST_DIR"])
KITTI_MAP = os.environ.get("OPENGRAPH_TEST_KITTI_MAP")
BIN = os.environ["OPENGRAPH_BIN"]


@pytest.fixture(scope="module")
def m():
    with opengraph.open(MAP) as m:
        yield m


def test_info_schema_and_query(m):
    info = m.info()
    n = m.query("MATCH (n:Instance) RETURN count(n) AS n")[0]["n"]
    assert n > 0
    assert info["nodes"]["Instance"] == n
    s = m.schema()
    assert s["nodes"]["Instance"] == n
    rows = m.query("MATCH (n:Instance) WHERE n.semantic_class = $c RETURN id(n) AS id LIMIT 3", {"c": "car"})
    assert all(isinstance(r["id"], int) for r in rows)
    a = m.query_answer("MATCH (n:Segment) RETURN n.kind AS kind ORDER BY kind")
    assert a["columns"] == ["kind"] and a["row_count"] == len(a["rows"])


def test_query_df(m):
    pd = pytest.importorskip("pandas")
    df = m.query_df("MATCH (n:Instance) RETURN n.semantic_class AS class, n.point_count AS points LIMIT 20")
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == ["class", "points"]


def test_find_locate_navigate_describe(m):
    f = m.find("a parked car", k=3)
    assert 1 <= len(f["results"]) <= 3
    best = f["results"][0]
    assert set(best) >= {"id", "caption", "semantic_class", "score", "centroid", "evidence"}
    assert len(best["centroid"]) == 3
    only = m.find("a parked car", k=5, semantic_class="car")
    assert all(r["semantic_class"] == "car" for r in only["results"])
    loc = m.locate("I'm at a T-junction", k=2)
    assert 1 <= len(loc["results"]) <= 2
    seg = loc["results"][0]["segment"]
    lane = m.query("MATCH (l:LaneNode {lane_id: 0}) RETURN id(l) AS id")[0]["id"]
    nav = m.navigate(f"lane:{lane}", f"segment:{seg}")
    assert nav["plan"]["route"]["length_m"] >= 0
    assert nav["plan"]["path"]["poses"] == []
    withposes = m.navigate(f"lane:{lane}", f"segment:{seg}", poses=True)
    assert len(withposes["plan"]["path"]["poses"]) > 0
    area = m.describe_area()
    assert len(area["segments"]) == m.schema()["nodes"]["Segment"]
    one = m.describe_area(seg)
    assert one["id"] == seg


def test_task_tools_agree_with_cypher(m):
    # the nearest car to the start of the drive, and its distance, as Cypher computes them
    start = m.query("MATCH (f:Frame) WITH f ORDER BY f.index LIMIT 1 "
                    "RETURN f.world_from_velo[3] AS x, f.world_from_velo[11] AS z")[0]
    near = m.nearest("cars", "the start of the drive", k=1)
    assert near["near"]["resolved"]["by"] == "drive"
    best = near["results"][0]
    c = m.query("MATCH (i:Instance) WHERE id(i) = $id RETURN i.centroid.x AS x, i.centroid.z AS z",
                {"id": best["id"]})[0]
    assert abs(best["distance_m"] - ((c["x"] - start["x"]) ** 2 + (c["z"] - start["z"]) ** 2) ** 0.5) < 1e-6
    everything = m.count("cars", list=0)
    assert everything["count"] >= 1 and everything["objects"] == []
    circle = m.count("cars", near="the start of the drive", radius_m=best["distance_m"] + 1e-6)
    assert circle["count"] >= 1
    d = m.distance(f"instance:{best['id']}", "the start of the drive")
    assert abs(d["distance_m"] - best["distance_m"]) < 1e-6
    around = m.neighbours(best["id"], radius_m=50.0, k=5)
    gaps = [n["gap_m"] for n in around["neighbours"]]
    assert gaps == sorted(gaps) and all(g <= 50.0 for g in gaps)


def test_instance_points_are_float32_in_the_world_frame(m):
    row = m.query("MATCH (n:Instance) WHERE n.point_count > 10 RETURN id(n) AS id, n.point_count AS k LIMIT 1")[0]
    inst = m.instance(row["id"])
    assert isinstance(inst, opengraph.Instance)
    assert inst.points.dtype == np.float32
    assert inst.points.shape == (row["k"], 3)
    assert inst.centroid.shape == (3,) and inst.centroid.dtype == np.float64
    # the centroid lies within the points' extent (both world frame, metres)
    lo, hi = inst.points.min(axis=0) - 1e-3, inst.points.max(axis=0) + 1e-3
    assert np.all(inst.centroid >= lo) and np.all(inst.centroid <= hi)
    assert inst.caption


def test_every_exception_class(m, tmp_path):
    assert issubclass(opengraph.InputError, opengraph.OpenGraphError)
    for cls in (opengraph.NotFoundError, opengraph.ConstraintError, opengraph.ReadOnlyError,
                opengraph.TimeoutError, opengraph.BusyError):
        assert issubclass(cls, opengraph.OpenGraphError)
    with pytest.raises(opengraph.InputError, match="line 1"):
        m.query("MATCH (n RETURN n")
    with pytest.raises(opengraph.InputError):
        m.find("", k=3)
    with pytest.raises(opengraph.InputError):
        m.find("a car", k=0)
    with pytest.raises(opengraph.NotFoundError):
        m.instance(10**12)
    with pytest.raises(opengraph.ReadOnlyError):
        m.update("the bench is gone")
    with pytest.raises(opengraph.NotFoundError):
        opengraph.open(tmp_path / "nothing.og")
    with pytest.raises(opengraph.InputError, match="embedder"):
        opengraph.open(MAP, embedder="word2vec")
    with opengraph.open(MAP, timeout_secs=0.001) as hurried:
        with pytest.raises(opengraph.TimeoutError):
            hurried.find("a parked car by the crossroads", k=10)
    # a write the schema refuses: an Instance needs its caption
    db = tmp_path / "w.og"
    shutil.copy(MAP, db)
    with opengraph.open(db, read_only=False) as w:
        with pytest.raises(opengraph.ConstraintError):
            w.query("CREATE (:Instance {instance_id: -1})")
    closed = opengraph.open(MAP)
    closed.close()
    assert closed.closed
    with pytest.raises(opengraph.OpenGraphError, match="closed"):
        closed.info()


def test_threads_query_one_map_at_once(m):
    want = m.query("MATCH (n:Instance) RETURN count(n) AS n")[0]["n"]
    got, errors = [], []

    def work():
        try:
            for _ in range(5):
                got.append(m.query("MATCH (n:Instance) RETURN count(n) AS n")[0]["n"])
                m.find("a tree", k=2)
        except Exception as e:  # noqa: BLE001 - collected and asserted below
            errors.append(e)

    ts = [threading.Thread(target=work) for _ in range(4)]
    for t in ts:
        t.start()
    for t in ts:
        t.join(timeout=120)
    assert not errors
    assert got == [want] * 20


def test_update_and_undo_on_a_writable_copy(tmp_path):
    db = tmp_path / "edit.og"
    shutil.copy(MAP, db)
    with opengraph.open(db, read_only=False) as w:
        car = w.find("a car", k=1)["results"][0]
        before = w.query("MATCH (n:Instance) RETURN count(n) AS n")[0]["n"]
        prop = w.update(f"the {car['caption']} is gone")
        assert prop["applied"] is None
        if prop["ambiguous"] or prop["no_match"]:
            pytest.skip("the car's own caption is ambiguous on this map")
        done = w.update(f"the {car['caption']} is gone", apply=True)
        edit = done["applied"]["edit_id"]
        assert w.query("MATCH (n:Instance) RETURN count(n) AS n")[0]["n"] == before - 1
        w.undo(edit)
        assert w.query("MATCH (n:Instance) RETURN count(n) AS n")[0]["n"] == before
        with pytest.raises(opengraph.OpenGraphError):
            w.undo(edit)


def test_to_networkx_and_exports(m, tmp_path):
    nx = pytest.importorskip("networkx")
    g = m.to_networkx()
    info = m.info()
    assert g.number_of_nodes() == sum(info["nodes"].values())
    assert g.number_of_edges() == sum(info["relationships"].values())
    a = m.export("geojson", tmp_path / "m.geojson")
    assert a["format"] == "geojson" and "metres" in a["frame"]
    gj = json.loads((tmp_path / "m.geojson").read_text())
    assert len(gj["features"]) == a["nodes"]
    c = m.export("neo4j-csv", tmp_path / "csv")
    assert "nodes_Instance.csv" in c["files"]
    with pytest.raises(opengraph.InputError, match="no export format|unknown variant"):
        m.export("xml", tmp_path / "x")
    assert isinstance(nx.MultiDiGraph(), nx.MultiDiGraph)


def test_sim_and_build_report_progress(tmp_path):
    seen = []
    r = opengraph.sim(tmp_path / "sim", seed=7, frames=12, progress=lambda d, t: seen.append((d, t)))
    assert r["frames"] == 12
    assert seen and seen[-1][0] == seen[-1][1]
    events = []
    b = opengraph.build(tmp_path / "sim", tmp_path / "m.og", detections=tmp_path / "sim" / "detections",
                        embedder="hash", progress=lambda e, v: events.append(e))
    assert sum(b["instances_per_class"].values()) > 0
    assert events[0] == "start" and "frame" in events and events[-1] == "finishing"
    with opengraph.open(tmp_path / "m.og") as m:
        assert m.info()["nodes"]["Instance"] > 0
    with pytest.raises(opengraph.InputError):
        opengraph.build(tmp_path / "nowhere", tmp_path / "n.og", detections=tmp_path / "nowhere")
    # an exception in the callback is raised after the operation
    with pytest.raises(ZeroDivisionError):
        opengraph.sim(tmp_path / "sim2", seed=7, frames=2, progress=lambda d, t: 1 / 0)


@pytest.mark.skipif(not KITTI_MAP, reason="no KITTI sample map (../shared/data absent)")
def test_the_kitti_sample_map():
    with opengraph.open(KITTI_MAP) as k:
        n = k.query("MATCH (n:Instance) RETURN count(n) AS n")[0]["n"]
        assert n > 0
        row = k.query("MATCH (n:Instance) WHERE n.point_count > 0 RETURN id(n) AS id LIMIT 1")[0]
        pts = k.instance(row["id"]).points
        assert pts.dtype == np.float32 and pts.shape[1] == 3
        env = k.query("MATCH (e:Environment) RETURN e.ground_frame AS g")
        assert env and env[0]["g"] == "kitti_cam"


def test_answers_equal_the_http_apis(tmp_path):
    served = tmp_path / "served.og"
    shutil.copy(MAP, served)
    p = subprocess.Popen([BIN, "serve", "--db", str(served), "--bind", "127.0.0.1:0"],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        line = p.stdout.readline()
        url = line[line.index("http://"):].split()[0].rstrip("/")

        def post(path, body):
            req = urllib.request.Request(url + path, data=json.dumps(body).encode(),
                                         headers={"Content-Type": "application/json"})
            with urllib.request.urlopen(req, timeout=60) as r:
                return json.loads(r.read())

        with opengraph.open(served) as m:
            for text in ("a parked car", "the bench near the bus stop"):
                http = post("/api/find", {"text": text, "k": 5})
                py = m.find(text, k=5)
                assert py == http
            q = "MATCH (s:Segment) RETURN s.kind AS kind, count(*) AS n ORDER BY kind"
            assert m.query_answer(q) == post("/api/cypher", {"query": q})
            start = time.perf_counter()
            for _ in range(20):
                m.find("a parked car", k=5)
            py_ms = (time.perf_counter() - start) / 20 * 1e3
            start = time.perf_counter()
            for _ in range(20):
                post("/api/find", {"text": "a parked car", "k": 5})
            http_ms = (time.perf_counter() - start) / 20 * 1e3
            print(f"find: python {py_ms:.2f} ms, http {http_ms:.2f} ms (mean of 20)")
    finally:
        p.kill()
        p.wait(timeout=30)


def test_the_readme_examples_run():
    here = pathlib.Path(__file__).resolve()
    for readme in (here.parents[1] / "README.md", here.parents[3] / "README.md"):
        text = readme.read_text()
        assert "```python\n" in text, readme
        code = text.split("```python\n", 1)[1].split("```", 1)[0]
        assert code.count("\n") <= 6, f"{readme}: the example is five lines or so"
        env = {"MAP": MAP}
        exec(compile(code.replace('"out/city.og"', "MAP"), str(readme), "exec"), env)
