#!/usr/bin/env python3
"""pyroomacoustics peer for `frusta-bench propagation`.

Reads a JSON job on stdin, writes a JSON result on stdout (nothing else goes
to stdout; library chatter is sent to stderr).

Job:
    {"rooms": [{"name": "shoebox",
                "walls": [{"corners": [[x,y,z], ...], "absorption": 0.1}, ...],
                "source": [x,y,z], "listener": [x,y,z],
                "max_order": 4}]}

Each wall is one planar polygon (three or more corners, convex or not),
counter-clockwise seen from inside the room (its normal points into the air),
metres, z up. `absorption` is the wall's energy absorption (all bands).

Result:
    {"rooms": [{"name", "seconds", "timed", "setup_seconds", "paths",
                "paths_by_order", "image_sources", "distances_m",
                "duplicates", "duplicate_tol_m", "distinct_positions",
                "duplicates_1e-6m", "duplicates_1mm", "orders",
                "walls", "obstructing_walls", "threads", "max_order",
                "version"} | {"name", "error"}, ...]}

`python pyroom_ism.py --selftest [--max-order N] [--split K] [--faces] [--full]`
builds a 10 x 6 x 3 m box whose 6 faces are each split into K x K cells of 2
triangles (K=4: 192 triangles, K=1: 12), one wall per triangle, or with
--faces one rectangle per face (6 walls), runs it and prints the result.
"""

import argparse
import contextlib
import json
import os
import sys
import time

import numpy as np

# libroom's Room::image_source_model is a plain recursive C++ search: no
# thread pool, no OpenMP.
THREADS = 1

TIMED = (
    "Room.image_source_model() only (single-threaded): the C++ depth-first image-source "
    "enumeration with visibility tests for the one microphone, plus the "
    "library's Python copy-out and is_inside check of the microphone. "
    "Room construction (walls, convex-hull test for obstructing walls, "
    "C++ room engine), adding source/microphone and our post-processing "
    "are excluded (construction is reported as setup_seconds)."
)


# Two visible image sources closer than this count as one position.
DUP_TOL_M = 1e-4


@contextlib.contextmanager
def stdout_to_stderr():
    """Redirect fd 1 (also C/C++ output) to stderr while pyroomacoustics runs."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def count_duplicates(points, tol):
    """Return (surplus, distinct): points closer than `tol` (chained) form one
    cluster; surplus = len(points) - number of clusters."""
    n = len(points)
    if n < 2:
        return 0, n
    from scipy.spatial import cKDTree

    parent = list(range(n))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in cKDTree(points).query_pairs(r=tol):
        ri, rj = find(i), find(j)
        if ri != rj:
            parent[ri] = rj
    distinct = len({find(i) for i in range(n)})
    return n - distinct, distinct


def run_room(room_job, pra):
    name = room_job.get("name", "")
    source = np.asarray(room_job["source"], dtype=np.float64)
    listener = np.asarray(room_job["listener"], dtype=np.float64)
    max_order = int(room_job["max_order"])

    t_setup = time.perf_counter()
    walls = []
    bad_normals = 0
    for k, wall in enumerate(room_job["walls"]):
        c = np.asarray(wall["corners"], dtype=np.float64)
        if c.ndim != 2 or c.shape[1] != 3 or len(c) < 3:
            raise ValueError(f"wall {k}: corners must be three or more [x,y,z]")
        # Newell's normal: right for non-convex polygons too; points into the room.
        our_n = np.cross(c, np.roll(c, -1, axis=0)).sum(axis=0)
        nn = np.linalg.norm(our_n)
        if nn == 0.0:
            raise ValueError(f"wall {k} has no area")
        # pyroomacoustics wants corners counter-clockwise around an OUTWARD
        # normal (Wall::reflect only mirrors sources lying on the normal's
        # negative side), so reverse our inward-facing winding.
        corners = np.ascontiguousarray(c[::-1].T)
        w = pra.wall_factory(
            corners, np.array([float(wall["absorption"])]), np.array([0.0]), name=f"w{k}"
        )
        if np.dot(np.asarray(w.normal, dtype=np.float64), our_n / nn) > -0.999:
            bad_normals += 1
        walls.append(w)
    if bad_normals:
        raise RuntimeError(
            f"{bad_normals} walls do not get the outward normal pyroomacoustics "
            "expects (winding convention changed?)"
        )

    # A Room built from walls (not a ShoeBox) handles non-convex rooms by
    # itself: Room._init_room_engine passes find_non_convex_walls(walls),
    # the walls off the convex hull, to libroom, which tests every image
    # source's legs against them (Room::is_obstructed_dfs).
    room = pra.Room(
        walls,
        fs=16000,
        max_order=max_order,
        air_absorption=False,
        ray_tracing=False,
        use_rand_ism=False,
    )
    room.add_source(source)
    room.add_microphone(listener)
    obstructing = list(getattr(room.room_engine, "obstructing_walls", []))
    setup_seconds = time.perf_counter() - t_setup

    t0 = time.perf_counter()
    room.image_source_model()
    seconds = time.perf_counter() - t0

    src = room.sources[0]
    vis = np.asarray(room.visibility[0])  # (n_mics, n_images)
    n_img = 0 if getattr(src, "images", None) is None else np.shape(src.images)[1]
    if vis.size == 0 or n_img == 0 or vis.shape[1] != n_img:
        images = np.zeros((0, 3))
        orders = np.zeros(0, dtype=int)
    else:
        mask = vis[0, :].astype(bool)
        images = np.asarray(src.images, dtype=np.float64).T[mask]
        orders = np.asarray(src.orders, dtype=int)[mask]
    by_order = np.bincount(orders, minlength=max_order + 1).tolist()
    dists = np.linalg.norm(images - listener[None, :], axis=1)
    # libroom computes in float32: a duplicate image reached through two
    # triangles of one plane can differ by a few float32 ulps (~4e-6 m at
    # 10 m), so 1e-6 m misses them; DUP_TOL_M is the tolerance that counts.
    dup, distinct = count_duplicates(images, DUP_TOL_M)
    dup_1e6, _ = count_duplicates(images, 1e-6)
    dup_mm, _ = count_duplicates(images, 1e-3)
    # sort by path length, then order, for stable output
    idx = np.lexsort((orders, dists))
    return {
        "name": name,
        "seconds": seconds,
        "timed": TIMED,
        "setup_seconds": setup_seconds,
        "walls": len(walls),
        "obstructing_walls": len(obstructing),
        "threads": THREADS,
        "max_order": max_order,
        "paths": int(len(images)),
        "paths_by_order": by_order,
        "image_sources": images[idx].tolist(),
        "orders": orders[idx].tolist(),
        "distances_m": dists[idx].tolist(),
        "duplicates": int(dup),
        "duplicate_tol_m": DUP_TOL_M,
        "distinct_positions": int(distinct),
        "duplicates_1e-6m": int(dup_1e6),
        "duplicates_1mm": int(dup_mm),
        "version": pra.__version__,
    }


def run_job(job):
    results = []
    with stdout_to_stderr():
        import pyroomacoustics as pra

        for room_job in job.get("rooms", []):
            try:
                results.append(run_room(room_job, pra))
            except Exception as e:  # one room's failure must not stop the others
                results.append(
                    {"name": room_job.get("name", ""), "error": f"{type(e).__name__}: {e}"}
                )
    return {"rooms": results}


def box_triangles(size=(10.0, 6.0, 3.0), split=4):
    """Axis-aligned box with a corner at the origin; every face split into
    split x split cells, each cell into 2 triangles, counter-clockwise seen
    from inside. 12 * split^2 triangles (split=4: 192)."""
    L, W, H = size
    o = np.zeros(3)
    ex, ey, ez = np.eye(3)
    # (origin, u, v) with u x v pointing into the room
    faces = [
        (o, L * ex, W * ey),  # floor z=0, +z
        (H * ez, W * ey, L * ex),  # ceiling z=H, -z
        (o, H * ez, L * ex),  # y=0, +y
        (W * ey, L * ex, H * ez),  # y=W, -y
        (o, W * ey, H * ez),  # x=0, +x
        (L * ex, H * ez, W * ey),  # x=L, -x
    ]
    tris = []
    for org, u, v in faces:
        for a in range(split):
            for b in range(split):
                p00 = org + u * a / split + v * b / split
                p10 = org + u * (a + 1) / split + v * b / split
                p11 = org + u * (a + 1) / split + v * (b + 1) / split
                p01 = org + u * a / split + v * (b + 1) / split
                tris.append([p00, p10, p11])
                tris.append([p00, p11, p01])
    tris = np.array(tris)
    centre = np.array(size) / 2
    for t in tris:  # normals point into the room
        n = np.cross(t[1] - t[0], t[2] - t[0])
        assert np.dot(n, centre - t.mean(axis=0)) > 0
    return tris.tolist()


def box_faces(size=(10.0, 6.0, 3.0)):
    """The same box as one rectangle per face, counter-clockwise seen from
    inside: each face's first triangle p00, p10, p11 plus p01."""
    faces = []
    for p00, p10, p11 in np.asarray(box_triangles(size, split=1))[::2]:
        faces.append({"corners": [p00, p10, p11, p00 + p11 - p10]})
    return [{"corners": np.asarray(f["corners"]).tolist()} for f in faces]


def selftest(args):
    split = args.split
    if args.faces:
        walls = box_faces()
        name = "shoebox-6-faces"
    else:
        walls = [{"corners": t} for t in box_triangles(split=split)]
        name = f"shoebox-{12 * split * split}"
    for w in walls:
        w["absorption"] = 0.1
    job = {
        "rooms": [
            {
                "name": name,
                "walls": walls,
                "source": args.source,
                "listener": args.listener,
                "max_order": args.max_order,
            }
        ]
    }
    out = run_job(job)
    if not args.full:
        for r in out["rooms"]:
            for k in ("image_sources", "distances_m", "orders"):
                r.pop(k, None)
    exact = [1, 6, 18, 38, 66][: args.max_order + 1]
    for r in out["rooms"]:
        if "error" in r:
            print(f"selftest {r['name']}: ERROR {r['error']}", file=sys.stderr)
        else:
            print(
                f"selftest {r['name']} order {args.max_order}: paths {r['paths']} "
                f"by order {r['paths_by_order']} (exact {sum(exact)} {exact}), "
                f"duplicates {r['duplicates']} (1e-6 m: {r['duplicates_1e-6m']}, "
                f"1 mm: {r['duplicates_1mm']}), distinct {r['distinct_positions']}, "
                f"ism {r['seconds']:.3f} s, setup {r['setup_seconds']:.3f} s",
                file=sys.stderr,
            )
    json.dump(out, sys.stdout, indent=1)
    sys.stdout.write("\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--selftest", action="store_true", help="run the built-in box room")
    ap.add_argument("--max-order", type=int, default=2)
    ap.add_argument("--split", type=int, default=4, help="cells per face edge (4: 192 triangles)")
    ap.add_argument("--source", type=float, nargs=3, default=[2.0, 3.0, 1.5])
    ap.add_argument("--listener", type=float, nargs=3, default=[7.3, 4.1, 1.7])
    ap.add_argument("--faces", action="store_true", help="selftest: one rectangle per face")
    ap.add_argument("--full", action="store_true", help="selftest: include image sources")
    args = ap.parse_args()
    if args.selftest:
        selftest(args)
        return
    job = json.load(sys.stdin)
    out = run_job(job)
    json.dump(out, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
