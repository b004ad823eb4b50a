#!/usr/bin/env python3
"""Where a 2D crack running along +x branches, at what angle, and how fast it ran before.

    python3 tools/crack_branch.py OUTDIR [--time T] [--threshold 0.3] [--from X] [--bin B]
                                         [--gap G] [--length L] [--rayleigh C]

The grown damage (damage >= threshold at time T, default the last frame; not in the first
frame) ahead of x = X (default: the farthest damaged node of the first frame, the notch tip) is
cut into slices of width B along x (default 4 mean node spacings). In each slice the damaged
nodes are grouped along y (a gap wider than G, default B, starts a new group; single nodes are
noise). The crack has branched where two or more groups persist for three slices in a row. The
two outermost groups over the next L (default 6 slices) are fitted with lines; their directions
are the branch angles (degrees from +x), and their intersection is the branching point (the
first slice with two groups lies past it, where the branches are a gap apart). With
OUTDIR/crack_tip.csv (from crack_tip.py) the mean tip speed from one slice past X to the
branching point is printed too, over the Rayleigh speed C when given.
"""
import argparse
import os
import sys

import numpy as np

from hooke_output import damage_points, frame_near, frames, read


def groups(y, gap):
    """Mean y of each run of sorted values with no gap wider than `gap` (two nodes or more)."""
    y = np.sort(y)
    runs = np.split(y, np.where(np.diff(y) > gap)[0] + 1) if len(y) else []
    return [float(r.mean()) for r in runs if len(r) >= 2]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outdir")
    ap.add_argument("--time", type=float)
    ap.add_argument("--threshold", type=float, default=0.3)
    ap.add_argument("--from", dest="start", type=float)
    ap.add_argument("--bin", type=float)
    ap.add_argument("--gap", type=float)
    ap.add_argument("--length", type=int, default=6)
    ap.add_argument("--rayleigh", type=float)
    a = ap.parse_args()
    fs = frames(a.outdir)
    m0 = read(fs[0][1])
    t, path = frame_near(fs, a.time) if a.time is not None else fs[-1]
    m = read(path)
    ref = np.asarray(m.points) - np.asarray(m.point_data["displacement"])
    lo, hi = ref.min(axis=0), ref.max(axis=0)
    if hi[2] - lo[2] > 0:
        raise SystemExit(f"{a.outdir}: a 3D body; crack_branch.py reads 2D plates")
    # Mean spacing from the nodes per area.
    h = float(np.sqrt((hi[0] - lo[0]) * (hi[1] - lo[1]) / len(ref)))
    width = a.bin or 4.0 * h
    gap = a.gap or width
    first = damage_points(m0, a.threshold)
    if a.start is not None:
        x0 = a.start
    elif len(first):
        x0 = float(first[:, 0].max())
    else:
        raise SystemExit("no damage in the first frame: give --from (the notch tip's x)")
    was = np.asarray(m0.point_data["damage"]) >= a.threshold
    grown = (np.asarray(m.point_data["damage"]) >= a.threshold) & ~was & (ref[:, 0] > x0)
    xs, ys = ref[grown, 0], ref[grown, 1]
    if len(xs) == 0:
        raise SystemExit(f"no grown damage ahead of x = {x0:g} at t = {t:.4e} s")
    edges = np.arange(x0, xs.max() + width, width)
    per = [groups(ys[(xs >= e) & (xs < e + width)], gap) for e in edges]
    at = next((i for i in range(len(per) - 2) if all(len(p) >= 2 for p in per[i:i + 3])), None)
    print(f"crack_branch: t = {t:.4e} s, slices {width:.3e} m wide from x = {x0:.4e} m")
    if at is None:
        print("crack_branch: no branching (never two damage groups for three slices in a row)")
        return 0
    up, down = [], []
    for i in range(at, min(at + a.length, len(per))):
        if len(per[i]) >= 2:
            xc = edges[i] + 0.5 * width
            up.append((xc, max(per[i])))
            down.append((xc, min(per[i])))
    xb, yb = edges[at], float(np.mean(per[at - 1])) if at > 0 and per[at - 1] else float(np.mean(per[at]))
    msg = ""
    if len(up) >= 3:
        (k1, c1), (k2, c2) = np.polyfit(*np.array(up).T, 1), np.polyfit(*np.array(down).T, 1)
        a1, a2 = np.degrees(np.arctan(k1)), np.degrees(np.arctan(k2))
        msg = f"; branches at {a1:+.1f} and {a2:+.1f} degrees, {a1 - a2:.1f} apart"
        if abs(k1 - k2) > 1e-9:
            xi = (c2 - c1) / (k1 - k2)
            # The lines meet behind the first two-group slice; trust that only within 3 slices.
            if edges[at] - 3 * width <= xi <= edges[at] + width:
                xb, yb = xi, k1 * xi + c1
    print(f"crack_branch: branches at x = {xb:.4e} m, y = {yb:.4e} m{msg}")
    tip = os.path.join(a.outdir, "crack_tip.csv")
    if os.path.exists(tip):
        rows = np.loadtxt(tip, delimiter=",", skiprows=1, ndmin=2)
        tx, tt = rows[:, 1], rows[:, 0]
        x1 = x0 + width
        i1, i2 = np.argmax(tx >= x1), np.argmax(tx >= xb)
        if tx[i1] >= x1 and tx[i2] >= xb and tt[i2] > tt[i1]:
            v = (tx[i2] - tx[i1]) / (tt[i2] - tt[i1])
            extra = f" = {v / a.rayleigh:.3f} c_R" if a.rayleigh else ""
            print(f"crack_branch: mean tip speed from x = {tx[i1]:.4e} to {tx[i2]:.4e} m "
                  f"(t = {tt[i1]:.4e} to {tt[i2]:.4e} s): {v:.4e} m/s{extra}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
