#!/usr/bin/env python3
"""The reference mapping steps through Open3D (PyPI `open3d` 0.20) and numpy, side by side with
opengraph's, on the same per-object inputs; run by `cargo bench -p ingest --bench open3d`,
which writes the inputs and its own outputs and times to DIR (see ingest/benches/open3d.rs).

For each key frame, as the reference implementation (ConceptGraphs-style) does: per object
detection `PointCloud.voxel_down_sample`, `cluster_dbscan` keeping the largest cluster,
`transform` to the world; association by the 3D IoU of axis-aligned boxes times w_geo plus the
feature cosine times w_fea, greedy one-to-one above the threshold (numpy); fusion by
`object_pcd += detection_pcd` then `voxel_down_sample`, the feature a running mean. Open3D runs on
one thread (OMP_NUM_THREADS=1, as opengraph's steps do).

Checks that both sides' outputs agree (per detection: voxels after the down-sample, points in
the largest cluster, the object it went to; the objects' point counts and boxes) and prints both
times per key frame and the ratio. Exits 1 when they disagree beyond float rounding.

    python3 scripts/bench_open3d.py --dir DIR [--reps N]

Installs open3d==0.20.0 into this Python when it is missing; says so and exits 0 when it cannot.
"""

import argparse
import json
import os
import statistics
import sys
import time

from peer import need

os.environ.setdefault("OMP_NUM_THREADS", "1")

OPEN3D = "open3d==0.20.0"


def need_open3d():
    return need("open3d", OPEN3D)


def load(d, np):
    with open(os.path.join(d, "inputs.json")) as f:
        inp = json.load(f)
    with open(os.path.join(d, "ours.json")) as f:
        ours = json.load(f)
    pts = np.fromfile(os.path.join(d, "points.f32"), dtype="<f4").reshape(-1, 3)
    dim = inp["feature_dim"]
    feats = np.fromfile(os.path.join(d, "features.f32"), dtype="<f4").reshape(-1, dim)
    frames = []
    k = 0
    for fr in inp["frames"]:
        dets = []
        for det in fr["detections"]:
            o, n = det["offset"], det["count"]
            dets.append((pts[o : o + n], feats[k]))
            k += 1
        frames.append((fr["index"], np.array(fr["world_from_velo"], dtype=np.float64).reshape(4, 4), dets))
    return inp, ours, frames


def largest_cluster(np, labels, points):
    """Indices of the largest cluster; ties go to the cluster holding the lexicographically
    smallest point (as the Rust side)."""
    if labels.size == 0 or labels.max() < 0:
        return None
    sizes = np.bincount(labels[labels >= 0])
    best = np.flatnonzero(sizes == sizes.max())
    if best.size > 1:
        def lexmin(c):
            p = points[labels == c]
            i = np.lexsort((p[:, 2], p[:, 1], p[:, 0]))[0]
            return tuple(p[i])

        c = min(best, key=lexmin)
    else:
        c = best[0]
    return np.flatnonzero(labels == c)


def iou_matrix(np, a_min, a_max, b_min, b_max):
    """3D IoU of axis-aligned boxes, (N, M)."""
    lo = np.maximum(a_min[:, None, :], b_min[None, :, :])
    hi = np.minimum(a_max[:, None, :], b_max[None, :, :])
    inter = np.clip(hi - lo, 0, None).prod(axis=2)
    va = np.clip(a_max - a_min, 0, None).prod(axis=1)
    vb = np.clip(b_max - b_min, 0, None).prod(axis=1)
    union = va[:, None] + vb[None, :] - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1), 0.0)


def run(o3d, np, inp, frames):
    v = inp["voxel_m"]
    eps, minp = inp["dbscan_eps_m"], inp["dbscan_min_points"]
    w_geo, w_fea, thr = inp["w_geo"], inp["w_fea"], inp["sim_threshold"]
    objects = []  # dicts: pcd, min, max, feature, n
    times, outs = [], []
    for index, pose, dets in frames:
        t = dict(voxel=0.0, dbscan=0.0, transform=0.0, associate=0.0, fuse=0.0)
        kept = []
        base = len(outs)
        for k, (pts, _) in enumerate(dets):
            s = time.perf_counter()
            pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts.astype(np.float64)))
            down = pcd.voxel_down_sample(v)
            t["voxel"] += time.perf_counter() - s
            s = time.perf_counter()
            labels = np.asarray(down.cluster_dbscan(eps=eps, min_points=minp, print_progress=False))
            idx = largest_cluster(np, labels, np.asarray(down.points))
            sel = down.select_by_index(idx) if idx is not None else None
            t["dbscan"] += time.perf_counter() - s
            s = time.perf_counter()
            if sel is not None:
                sel.transform(pose)
                wp = np.asarray(sel.points)
                kept.append((k, sel, wp.min(axis=0), wp.max(axis=0)))
            t["transform"] += time.perf_counter() - s
            outs.append(
                dict(frame=index, det=k, voxels=len(down.points),
                     kept=0 if idx is None else int(idx.size), object=None, matched=False)
            )
        s = time.perf_counter()
        assignment = [None] * len(kept)
        if kept and objects:
            dmin = np.array([x[2] for x in kept])
            dmax = np.array([x[3] for x in kept])
            omin = np.array([o["min"] for o in objects])
            omax = np.array([o["max"] for o in objects])
            iou = iou_matrix(np, dmin, dmax, omin, omax)
            df = np.array([dets[x[0]][1] for x in kept], dtype=np.float64)
            of = np.array([o["feature"] for o in objects], dtype=np.float64)
            dn = np.linalg.norm(df, axis=1, keepdims=True)
            on = np.linalg.norm(of, axis=1, keepdims=True)
            cos = (df / np.where(dn > 0, dn, 1)) @ (of / np.where(on > 0, on, 1)).T
            phi = w_geo * iou + w_fea * cos
            di, oi = np.nonzero(phi > thr)
            order = np.lexsort((oi, di, -phi[di, oi]))
            used = set()
            for q in order:
                d, o = int(di[q]), int(oi[q])
                if assignment[d] is None and o not in used:
                    assignment[d] = o
                    used.add(o)
        t["associate"] += time.perf_counter() - s
        s = time.perf_counter()
        for (k, sel, lo, hi), a in zip(kept, assignment):
            feat = dets[k][1]
            if a is None:
                objects.append(dict(pcd=sel, min=lo, max=hi, feature=feat.copy(), n=1))
                j = len(objects) - 1
            else:
                o = objects[a]
                o["pcd"] += sel
                o["pcd"] = o["pcd"].voxel_down_sample(v)
                p = np.asarray(o["pcd"].points)
                o["min"], o["max"] = p.min(axis=0), p.max(axis=0)
                o["feature"] = (o["feature"] * o["n"] + feat) / (o["n"] + 1)
                o["n"] += 1
                j = a
            outs[base + k]["object"] = j
            outs[base + k]["matched"] = a is not None
        t["fuse"] += time.perf_counter() - s
        times.append({key: 1e3 * val for key, val in t.items()})
    return times, outs, objects


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dir", required=True)
    ap.add_argument("--reps", type=int, default=20)
    args = ap.parse_args()
    if not need_open3d():
        print(f"skipping the Open3D side: {OPEN3D} could not be installed into {sys.executable}")
        return 0
    import numpy as np
    import open3d as o3d

    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    inp, ours, frames = load(args.dir, np)
    per_frame = [[] for _ in frames]
    stage = [dict(voxel=0.0, dbscan=0.0, transform=0.0, associate=0.0, fuse=0.0) for _ in frames]
    for _ in range(args.reps):
        times, outs, objects = run(o3d, np, inp, frames)
        for k, t in enumerate(times):
            per_frame[k].append(sum(t.values()))
            for key in t:
                stage[k][key] += t[key] / args.reps

    # agreement
    od = ours["detections"]
    n = len(od)
    same_vox = sum(a["voxels"] == b["voxels"] for a, b in zip(od, outs))
    same_kept = sum(a["kept"] == b["kept"] for a, b in zip(od, outs))
    same_obj = sum(a["object"] == b["object"] and a["matched"] == b["matched"] for a, b in zip(od, outs))
    vox_rel = max(abs(a["voxels"] - b["voxels"]) / max(1, b["voxels"]) for a, b in zip(od, outs))
    kept_rel = max(abs(a["kept"] - b["kept"]) / max(1, b["kept"]) for a, b in zip(od, outs))
    kept_abs = max(abs(a["kept"] - b["kept"]) for a, b in zip(od, outs))
    oo = ours["objects"]
    print(f"open3d {o3d.__version__}, numpy {np.__version__}, OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}")
    print(f"agreement over {n} detections: voxels equal {same_vox}/{n} (largest relative difference {vox_rel:.4f}), "
          f"largest-cluster points equal {same_kept}/{n} (at most {kept_abs} apart, {kept_rel:.4f}), same object {same_obj}/{n}")
    ok = len(oo) == len(objects)
    box_diff = 0.0
    pts_rel = 0.0
    if ok:
        for a, b in zip(oo, objects):
            p = np.asarray(b["pcd"].points)
            pts_rel = max(pts_rel, abs(a["points"] - len(p)) / max(1, len(p)))
            box_diff = max(box_diff, float(np.abs(np.array(a["min"]) - b["min"]).max()),
                           float(np.abs(np.array(a["max"]) - b["max"]).max()))
        print(f"objects: {len(oo)} both; point counts within {pts_rel:.4f} relative, box corners within {box_diff:.4f} m")
    else:
        print(f"objects: opengraph {len(oo)}, open3d {len(objects)}: DISAGREE")
    # Float rounding at a voxel's edge may move a point; a DBSCAN border point (within eps of two
    # clusters' core points) goes to whichever cluster reaches it first, which depends on the
    # order the points come in (Open3D's voxel output order is its hash map's). Anything beyond
    # a few points is a disagreement.
    agree = ok and vox_rel <= 0.01 and kept_abs <= 3 and same_obj >= 0.98 * n and box_diff <= 0.2

    print()
    print("| key frame | detections | opengraph p50 ms | open3d p50 ms | ratio |")
    print("|---|---|---|---|---|")
    ours_total = 0.0
    o3d_total = 0.0
    for k, (index, _, dets) in enumerate(frames):
        a = ours["frame_ms_p50"][k]
        b = statistics.median(per_frame[k])
        ours_total += a
        o3d_total += b
        print(f"| {index} | {len(dets)} | {a:.2f} | {b:.2f} | {b / a:.1f}x |")
    print(f"| all | {sum(len(f[2]) for f in frames)} | {ours_total / len(frames):.2f} per frame | "
          f"{o3d_total / len(frames):.2f} per frame | **{o3d_total / ours_total:.1f}x** |")
    print()
    print("mean ms per key frame by step (opengraph / open3d):")
    for key in ["voxel", "dbscan", "transform", "associate", "fuse"]:
        a = statistics.fmean(s[key] for s in ours["stage_ms_mean"])
        b = statistics.fmean(s[key] for s in stage)
        ratio = f"{b / a:.1f}x" if a > 0 else "-"
        print(f"  {key:10s} {a:8.3f} / {b:8.3f}  {ratio}")
    print(f"opengraph {ours['reps']} repetitions, open3d {args.reps}")
    if not agree:
        print("the outputs DISAGREE beyond float rounding")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
