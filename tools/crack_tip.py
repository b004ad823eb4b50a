#!/usr/bin/env python3
"""Crack-tip position and speed against time, from the damage field of a hooke run.

    python3 tools/crack_tip.py OUTDIR [--threshold 0.2] [--origin X,Y[,Z]] [--rayleigh C]
                                      [--window K] [--edge D]

The tip is the newly damaged node (damage >= threshold now, not in the first frame: pre-cracks
do not count) farthest from the origin (default: the damaged node of the first frame with the
largest x, i.e. the end of a pre-crack running along +x). The speed column is the central difference of that distance over time. Writes
OUTDIR/crack_tip.csv and prints the largest speed (and its ratio to the Rayleigh speed C, m/s,
when given). The largest speed is taken over K frames (default 1; on a random lattice the
farthest damaged node jitters by a spacing, so a few frames give a steadier figure), and only
while the tip is farther than D (default 2 % of the body's size) from the body's bounding box:
once the crack has reached the far boundary the farthest damaged node is wherever the last
ligament failed, not a tip, and its jump is no speed.
"""
import argparse
import os

import numpy as np

from hooke_output import damage_points, frames, read


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outdir")
    ap.add_argument("--threshold", type=float, default=0.2)
    ap.add_argument("--origin")
    ap.add_argument("--rayleigh", type=float)
    ap.add_argument("--window", type=int, default=1)
    ap.add_argument("--edge", type=float)
    a = ap.parse_args()
    fs = frames(a.outdir)
    m0 = read(fs[0][1])
    first = damage_points(m0, a.threshold)
    was = np.asarray(m0.point_data["damage"]) >= a.threshold
    if a.origin:
        origin = np.array([float(v) for v in a.origin.split(",")] + [0.0] * 3)[:3]
    elif len(first):
        origin = first[np.argmax(first[:, 0])]
    else:
        raise SystemExit("no damage in the first frame: give --origin (the notch tip)")
    rows = []
    for t, path in fs:
        m = read(path)
        ref = np.asarray(m.points) - np.asarray(m.point_data["displacement"])
        pts = ref[(np.asarray(m.point_data["damage"]) >= a.threshold) & ~was]
        if len(pts) == 0:
            rows.append((t, *origin, 0.0))
            continue
        d = np.linalg.norm(pts - origin, axis=1)
        k = int(np.argmax(d))
        rows.append((t, *pts[k], float(d[k])))
    rows = np.array(rows)
    speed = np.gradient(rows[:, 4], rows[:, 0]) if len(rows) > 1 else np.zeros(len(rows))
    out = os.path.join(a.outdir, "crack_tip.csv")
    np.savetxt(out, np.column_stack([rows, speed]), delimiter=",", header="time,tip_x,tip_y,tip_z,length,speed", comments="")
    # Frames with the tip inside the body, away from its bounding box (the crack has not yet
    # reached the far boundary).
    ref0 = np.asarray(m0.points) - np.asarray(m0.point_data["displacement"])
    lo, hi = ref0.min(axis=0), ref0.max(axis=0)
    edge = a.edge if a.edge is not None else 0.02 * float(np.max(hi - lo))
    flat = hi - lo > 0
    away = np.array([bool(np.all(((r[1:4] - lo) > edge) | ~flat) and np.all(((hi - r[1:4]) > edge) | ~flat)) for r in rows])
    n_in = len(rows) if away.all() else int(np.argmin(away))
    k = max(a.window, 1)
    vmax = 0.0
    for i in range(0, max(n_in - k, 0)):
        j = i + k
        vmax = max(vmax, (rows[j, 4] - rows[i, 4]) / (rows[j, 0] - rows[i, 0]))
    msg = f"crack_tip: growth {rows[-1, 4]:.4e} m, largest speed {vmax:.4e} m/s"
    if a.rayleigh:
        msg += f" = {vmax / a.rayleigh:.3f} c_R"
    if n_in < len(rows):
        msg += f" (until t = {rows[n_in - 1, 0]:.4e} s; the crack then reached the boundary)"
    print(msg + f"; wrote {out}")


if __name__ == "__main__":
    main()
