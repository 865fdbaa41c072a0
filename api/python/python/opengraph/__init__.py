"""OpenGraph from Python: open a map, ask it in words, query it in Cypher, get its points.

    import opengraph
    with opengraph.open("out/city.og") as m:
        best = m.find("somewhere to sit while waiting for the bus", k=3)["results"][0]
        print(best["caption"], m.instance(best["id"]).points.shape)

Every method runs the same service operation as the HTTP API and returns the same answer
(JSON as Python dicts and lists). Ids are node ids, as `find`, `query` and `navigate` print
them. Positions are metres in the map's world frame: KITTI's camera frame (x right, y down,
z forward; the ground plane is x, z) or east-north-up (ground x, y; up z), as
``info()["ground_frame"]`` or the Environment node says. Long calls release the GIL; threads
may share one map.

Errors are `OpenGraphError` or one of its subclasses: `InputError` (bad arguments, bad Cypher,
missing or malformed files), `NotFoundError`, `ConstraintError`, `ReadOnlyError`,
`TimeoutError` and `BusyError`; the messages are the CLI's.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Optional, Sequence

import numpy as np

from . import _opengraph
from ._opengraph import (
    BusyError,
    ConstraintError,
    InputError,
    NotFoundError,
    OpenGraphError,
    ReadOnlyError,
    TimeoutError,
)

__version__ = _opengraph.__version__

__all__ = [
    "open",
    "sim",
    "build",
    "Map",
    "Instance",
    "OpenGraphError",
    "InputError",
    "NotFoundError",
    "ConstraintError",
    "ReadOnlyError",
    "TimeoutError",
    "BusyError",
]


@dataclass(frozen=True)
class Instance:
    """One mapped object (an ``Instance`` node).

    Attributes:
        id: its node id.
        properties: its properties (caption, class, centroid as ``{x, y, z}``, bbox, ...;
            the feature vectors and caption list left out), as ``get_instance`` gives them.
        segment: its road segment ``{"id", "kind"}``, or None.
        related: its ``RELATED`` neighbours, each ``{"id", "outgoing", "relation",
            "distance_m", "source", "caption"}``.
        points: its fused LiDAR points, an ``(N, 3)`` ``float32`` array in the world frame,
            metres.
    """

    id: int
    properties: dict
    segment: Optional[dict]
    related: list
    points: np.ndarray

    @property
    def caption(self) -> str:
        """The instance's caption."""
        return self.properties.get("caption", "")

    @property
    def centroid(self) -> np.ndarray:
        """The centroid, a ``(3,)`` ``float64`` array in the world frame, metres."""
        c = self.properties["centroid"]
        return np.array([c["x"], c["y"], c["z"]], dtype=np.float64)


class Map:
    """An open OpenGraph map. Make one with :func:`opengraph.open`; use it as a context
    manager (``with opengraph.open(path) as m:``) or call :meth:`close`."""

    def __init__(self, native: Any):
        self._native = native

    # --- plumbing -----------------------------------------------------------------------
    def _call(self, tool: str, **args: Any) -> Any:
        args = {k: v for k, v in args.items() if v is not None}
        return json.loads(self._native.call(tool, json.dumps(args)))

    def __enter__(self) -> "Map":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self.closed else ("read-only" if self.read_only else "writable")
        return f"<opengraph.Map {os.fspath(self.path)!r} {state}>"

    def close(self) -> None:
        """Closes the map; calls after it raise `OpenGraphError`."""
        self._native.close()

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._native.closed

    @property
    def path(self) -> str:
        """The store file."""
        return self._native.path

    @property
    def read_only(self) -> bool:
        """Whether the map was opened read-only."""
        return self._native.read_only

    # --- reading ------------------------------------------------------------------------
    def info(self) -> dict:
        """The map's summary: node counts per label, relationship counts per type."""
        return json.loads(self._native.info())

    def schema(self) -> dict:
        """Labels and relationship types with counts, the indexes, and what each layer
        means (the ``get_schema`` tool)."""
        return self._call("get_schema")

    def query(
        self, cypher: str, params: Optional[dict] = None, full_properties: bool = False
    ) -> list[dict]:
        """Runs a Cypher statement and returns its rows, each a dict by column.

        Whole nodes and relationships come with their vectors (``feature``) and long
        coordinate lists (polygons) summarised as a short string unless ``full_properties``
        is true; a property returned on its own (``RETURN n.feature``) is always whole.

        Read-only maps take reads only (writes are refused by the parser, `InputError`);
        a map opened with ``read_only=False`` runs writes too, as one transaction. At most
        1000 rows and 10 s per statement, as over HTTP (`InputError` past the rows,
        `TimeoutError` past the time). Parameters are ``$name`` in the statement.
        """
        return self.query_answer(cypher, params, full_properties)["rows"]

    def query_answer(
        self, cypher: str, params: Optional[dict] = None, full_properties: bool = False
    ) -> dict:
        """Like :meth:`query`, with the whole answer: ``columns``, ``rows``, ``row_count``,
        ``stats`` (what a write changed) and ``plan`` (for EXPLAIN and PROFILE)."""
        tool = "read_cypher" if self.read_only else "write_cypher"
        extra = {"full_properties": True} if full_properties else {}
        return self._call(tool, query=cypher, params=params, **extra)

    def query_df(
        self, cypher: str, params: Optional[dict] = None, full_properties: bool = False
    ):
        """:meth:`query` as a pandas DataFrame, its columns in the statement's order (needs
        pandas)."""
        import pandas as pd

        a = self.query_answer(cypher, params, full_properties)
        return pd.DataFrame(a["rows"], columns=a["columns"])

    def find(self, text: str, k: int = 5, semantic_class: Optional[str] = None,
             class_: Optional[str] = None) -> dict:
        """Finds objects from a request in words ("the bench near the bus stop", "somewhere
        I can post a letter"), graph-aware: target, anchors and relations, segments.

        Args:
            text: the request, 1 to 2000 characters.
            k: how many objects, 1 to 50.
            semantic_class: only objects of this SemanticKITTI class (``class_`` is the
                same, as earlier versions named it).

        Returns:
            ``{"request": the parsed request, "results": [...]}``, best first; each result
            has ``id`` (node id), ``label`` (what it is, in words), ``caption``,
            ``semantic_class`` (its SemanticKITTI class), ``score``, ``cosine``, ``centroid``
            ``[x, y, z]`` (world frame, metres), ``segment`` ``[id, kind]`` and ``evidence``.
        """
        return self._call("find_objects", text=text, k=k, **({"semantic_class": semantic_class or class_} if semantic_class or class_ else {}))

    def locate(self, text: str, k: int = 3) -> dict:
        """Where is someone who describes their surroundings ("I'm at a T-junction, there's
        a bus stop on my left")? Returns ``{"results": [...]}``: road segments best first,
        each with ``segment`` (node id), ``kind``, ``score``, ``position`` ``[a, b]`` (ground
        plane, metres) and ``evidence``."""
        return self._call("locate", text=text, k=k)

    def navigate(self, start: str, goal: str, poses: bool = False) -> dict:
        """Plans a route between two ends, each in words ("the bus stop by the crossroads")
        or as a spec (``lane:ID``, ``segment:ID``, ``instance:ID``, ``node:ID``, ``"x,z"``).
        Returns ``{"start", "goal", "plan"}``; ``plan["route"]["length_m"]`` is the route's
        length along the lane graph, metres; with ``poses`` the planned path's poses
        ``[a, b, heading]`` (ground plane, radians)."""
        return self._call("plan_route", **{"from": start, "to": goal, "poses": poses})

    def describe_area(self, segment_id: Optional[int] = None) -> dict:
        """The environment and its segments, or (with a Segment node id) one segment's
        objects by class and its notable objects."""
        return self._call("describe_area", segment_id=segment_id)

    def nearest(self, kind: str, near: str, k: int = 5, measure: str = "centroid",
                parts: bool = True) -> dict:
        """The ``k`` objects of a kind ("post box", "trees") nearest a place (words such as
        "the start of the drive" or "the T-junction", or a spec as for `navigate`), nearest
        first. ``measure``: ``"centroid"`` (ground-plane distance between centroids) or
        ``"box_gap"`` (between footprints). Returns ``{"kind", "near", "measure",
        "results"}``, each result with ``id``, ``label``, ``how`` (same, kind_of, part_of,
        similar) and ``distance_m``."""
        return self._call("nearest_objects", kind=kind, near=near, k=k, measure=measure,
                          parts=parts)

    def count(self, kind: str, within: Optional[str] = None, near: Optional[str] = None,
              radius_m: Optional[float] = None, list: int = 20, parts: bool = True) -> dict:
        """How many objects of a kind there are on the whole map, in one road segment
        (``within``: words or ``segment:ID``) or within ``radius_m`` of ``near``. Returns
        ``{"kind", "area", "count", "by_match", "measure", "objects"}``."""
        return self._call("count_objects", kind=kind, within=within, near=near,
                          radius_m=radius_m, list=list, parts=parts)

    def distance(self, a: str, b: str, measure: str = "centroid") -> dict:
        """The ground-plane distance between two places (words or specs), metres:
        ``{"from", "to", "distance_m", "measure"}``."""
        return self._call("measure_distance", **{"from": a, "to": b, "measure": measure})

    def neighbours(self, id: int, radius_m: float = 10.0, k: int = 10) -> dict:
        """What stands around an instance (node id): the objects whose footprints lie within
        ``radius_m`` of its own, nearest first, with ``gap_m``, ``centroid_distance_m`` and
        the map's geometric ``relation``."""
        return self._call("neighbours", id=id, radius_m=radius_m, k=k)

    def instance(self, id: int) -> Instance:
        """One instance by node id, with its points (an ``(N, 3)`` ``float32`` array, world
        frame, metres). Raises `NotFoundError` for an id no node has, `InputError` for a node
        that is not an Instance."""
        a = self._call("get_instance", id=id)
        n, raw = self._native.points(id)
        pts = np.frombuffer(raw, dtype="<f4").reshape(n, 3).astype(np.float32, copy=False)
        return Instance(a["id"], a["properties"], a["segment"], a["related"], pts)

    def tools(self) -> list[dict]:
        """The agent tools this map offers (name, description, input and output schemas)."""
        return json.loads(self._native.tools())

    def call(self, tool: str, args: Optional[dict] = None) -> Any:
        """Calls an agent tool by name with its arguments, as MCP and HTTP do."""
        return json.loads(self._native.call(tool, json.dumps(args or {})))

    # --- writing ------------------------------------------------------------------------
    def update(self, text: str, apply: bool = False) -> dict:
        """Proposes (and with ``apply=True`` commits) a map edit from a described change:
        "the bush under the street sign at the crossing is gone". Needs a map opened with
        ``read_only=False`` (`ReadOnlyError` otherwise). ``answer["applied"]["edit_id"]`` is
        what :meth:`undo` takes."""
        return self._call("update_map", text=text, apply=apply)

    def undo(self, edit_id: int) -> dict:
        """Undoes an applied map edit exactly (needs ``read_only=False``)."""
        return self._call("undo_map_edit", edit_id=edit_id)

    # --- getting it out -----------------------------------------------------------------
    def to_networkx(self):
        """The whole map as a networkx ``MultiDiGraph``: nodes by node id with ``labels`` and
        every property, edges with ``type``, ``key`` (the relationship id) and properties
        (needs networkx 3.4 or later)."""
        import networkx as nx

        data = json.loads(self._native.node_link())
        return nx.node_link_graph(data, edges="edges")

    def export(self, format: str, path: "os.PathLike[str] | str", edges_key: str = "edges",
               colour: str = "class") -> dict:
        """Writes the map in another tool's format and returns what was written.

        Args:
            format: ``node-link``, ``graphml``, ``neo4j-csv`` (a folder of CSV files for
                ``neo4j-admin database import``), ``geojson`` (ground-plane metres),
                ``spark-dsg`` (Hydra's scene-graph JSON, z-up metres) or ``ply`` (points).
            path: the file, or for neo4j-csv the folder (made if missing).
            edges_key: node-link only: ``edges`` or ``links`` (networkx before 3.6).
            colour: ply only: ``class`` or ``instance``.
        """
        req = {"format": format, "edges_key": edges_key, "colour": colour}
        return json.loads(self._native.export(json.dumps(req), os.fspath(path)))


def open(path: "os.PathLike[str] | str", read_only: bool = True, embedder: Optional[str] = None,
         workers: int = 2, timeout_secs: float = 30.0) -> Map:
    """Opens the map (a ``.og`` store file).

    Args:
        path: the store file.
        read_only: open for reading only (any number of processes at once); ``False`` opens
            it for writing (one process), which :meth:`Map.update`, :meth:`Map.undo` and
            writing Cypher need.
        embedder: ``minilm`` or ``hash``; default: the one the map was built with.
        workers: readers, so that this many threads query at once.
        timeout_secs: how long one operation may take.

    Raises:
        NotFoundError: no store at ``path``.
        InputError: the store is in use by a writer, or the embedder disagrees with the map.
    """
    return Map(_opengraph.open(os.fspath(path), read_only, embedder, workers, timeout_secs))


def sim(out: "os.PathLike[str] | str", seed: int = 0, size: str = "small",
        frames: Optional[int] = None, progress: Optional[Callable[[int, int], None]] = None,
        **options: Any) -> dict:
    """Generates a synthetic city and a drive through it into ``out``: a KITTI-layout
    sequence (calibration, 10 Hz poses, LiDAR scans with SemanticKITTI labels), detections
    files and ground truth. The same seed gives byte-identical files.

    Args:
        out: the output folder (must not hold a sequence yet).
        seed: the seed.
        size: ``small`` (about 1 km of road), ``medium`` or ``city``.
        frames: sensor frames (default 300 for small).
        progress: called as ``progress(done, total)`` while frames are written.
        options: the other ``opengraph sim`` settings by name (``miss_rate``,
            ``no_noise``, ``moving_cars``, ...).

    Returns:
        The simulation report (road length, objects per class, frames, detections, ...).
    """
    req = {"out": os.fspath(out), "seed": seed, "size": size, **options}
    if frames is not None:
        req["frames"] = frames
    return json.loads(_opengraph.sim(json.dumps(req), progress))


def build(kitti: "os.PathLike[str] | str", db: "os.PathLike[str] | str",
          detections: "os.PathLike[str] | str | None" = None, oracle_labels: bool = False,
          frames: Optional[Sequence[int]] = None, embedder: str = "minilm",
          progress: Optional[Callable[[str, Any], None]] = None, **options: Any) -> dict:
    """Builds a map from a KITTI-layout sequence and its detections (or the SemanticKITTI
    label oracle) into the store ``db``.

    Args:
        kitti: the sequence folder (velodyne/, calib.txt, poses.txt).
        db: the store file to create (or to go on with, with ``resume=True``).
        detections: a folder of detections files; or pass ``oracle_labels=True``.
        frames: key frames ``(a, b)``, half-open.
        embedder: ``minilm`` or ``hash`` (tests only).
        progress: called as ``progress(event, value)``: ``("start", (done, total))``,
            ``("frame", n)``, ``("committed", n)``, ``("finishing", None)``.
        options: the other ``opengraph build`` settings by name (``stride``, ``resume``,
            ``config``, ``name``, ``accumulate``, ``poses``, ``llm``).

    Returns:
        The build report (instances per class, post-processing, hierarchy, timings, ...).
    """
    req = {"kitti": os.fspath(kitti), "db": os.fspath(db), "embedder": embedder,
           "oracle_labels": oracle_labels, **options}
    if detections is not None:
        req["detections"] = os.fspath(detections)
    if frames is not None:
        req["frames"] = list(frames)
    for k in ("config", "poses"):
        if req.get(k) is not None:
            req[k] = os.fspath(req[k])
    return json.loads(_opengraph.build(json.dumps(req), progress))
