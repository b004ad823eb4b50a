#!/usr/bin/env python3
"""Check the rigid-body series of a hooke run with real readers (meshio and pyvista).

    python3 tools/check_rigid.py OUTDIR

Every STEM_rigid_*.vtu must open in both readers with its cells and the `velocity`,
`reaction` and `body` fields; in the last frame each body's surface must be centred on the
position the contact history (STEM_contact.csv) gives for it at that time, to 1e-6 of its
size (symmetric shapes: spheres, boxes, cylinders). Exits 1 on any failure.
"""
import csv
import glob
import os
import sys

import meshio
import numpy as np
import pyvista as pv


def main():
    out = sys.argv[1]
    files = sorted(glob.glob(os.path.join(out, "*_rigid_*.vtu")))
    fails = 0
    if not files:
        print("check_rigid: no rigid-body frames")
        return 1
    for f in files:
        m = meshio.read(f)
        g = pv.read(f)
        ok = m.points.shape[0] > 0 and sum(len(c.data) for c in m.cells) > 0
        ok &= all(k in m.point_data for k in ("velocity", "reaction")) and "body" in m.cell_data
        ok &= g.n_points == m.points.shape[0]
        if not ok:
            print(f"check_rigid: {f} is incomplete")
            fails += 1
    stem = os.path.basename(files[-1]).rsplit("_rigid_", 1)[0]
    rows = list(csv.DictReader(open(os.path.join(out, f"{stem}_contact.csv"))))
    last = read_last(files[-1])
    for body, centre in last.items():
        mine = [r for r in rows if int(r["body"]) == body]
        # The history holds each step's start; the last frame is one step after the last row:
        # extrapolate with the last step's displacement.
        p1 = np.array([float(mine[-1][k]) for k in ("x", "y", "z")])
        p0 = np.array([float(mine[-2][k]) for k in ("x", "y", "z")])
        pos = 2.0 * p1 - p0
        err = np.abs(centre - pos).max()
        size = 1.0 + np.abs(pos).max()
        if err > 1e-6 * size:
            print(f"check_rigid: body {body} drawn at {centre}, history says {pos}")
            fails += 1
    print(f"check_rigid: {len(files)} frames, {len(last)} bodies, {fails} failures")
    return 1 if fails else 0


def read_last(path):
    m = meshio.read(path)
    points_of = {}
    for block, ids in zip(m.cells, m.cell_data["body"]):
        for cell, b in zip(block.data, ids):
            points_of.setdefault(int(b), set()).update(int(i) for i in cell)
    centres = {}
    for b, idx in points_of.items():
        p = m.points[sorted(idx)]
        centres[b] = 0.5 * (p.min(axis=0) + p.max(axis=0))
    return centres


if __name__ == "__main__":
    sys.exit(main())
