#!/usr/bin/env python3
"""Crack angle(s) from a hooke run, for the Kalthoff-Winkler test.

    python3 tools/crack_angle.py OUTDIR --tip X,Y[,SIDE] [--tip ...] [--radius R] [--threshold 0.2] [--ahead] [--time T] [--from R0] [--slabs K]

For each notch tip, the nodes that became damaged during the run (damage >= threshold in the
last frame, not in the first) within R of the tip (default: a fifth of the body's size) are
fitted with a line through the tip (principal direction of their offsets). The angle is
measured from the notch direction (+x, the notches run along x into the plate), positive
towards +y. Prints one angle per tip; Kalthoff and Winkler observed about 70 degrees.
With --ahead only the nodes ahead of the tip (x beyond it) count: in the Kalthoff-Winkler test
the damage behind the tips is the crushed impact zone, not the crack. SIDE (+1 or -1) keeps only
the nodes above (+1) or below (-1) the tip: the side a Kalthoff-Winkler crack runs to, away
from the impact zone between the notches. With --time T the frame nearest to T is measured
instead of the last: the Kalthoff-Winkler angle is the direction in which
the cracks leave the tips, before they branch and before the waves reflected from the back edge
open cracks of their own. With --from R0 only the damaged nodes at least R0 from the tip count,
and the line is fitted through their centroid instead of through the tip: the direction of the
crack path away from the tip, where a crack that first runs a little along the notch line and
then turns would otherwise be averaged with that first part. With --slabs K (3D plates) the
angle is also measured in each of K slabs of the thickness (z), after the one over all of it:
the crack front's angle through the thickness. Distances are in the plate's plane (x, y).
"""
import argparse
import math

import numpy as np

from hooke_output import frame_near, frames, read


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outdir")
    ap.add_argument("--tip", action="append", required=True)
    ap.add_argument("--radius", type=float)
    ap.add_argument("--threshold", type=float, default=0.2)
    ap.add_argument("--ahead", action="store_true")
    ap.add_argument("--time", type=float)
    ap.add_argument("--from", dest="r0", type=float, default=0.0)
    ap.add_argument("--slabs", type=int, default=1)
    a = ap.parse_args()
    fs = frames(a.outdir)
    last = fs[-1] if a.time is None else frame_near(fs, a.time)
    if a.time is not None:
        print(f"crack_angle: frame at t = {last[0]:.6e} s")
    m0, m1 = read(fs[0][1]), read(last[1])
    ref = np.asarray(m1.points) - np.asarray(m1.point_data["displacement"])
    new = (np.asarray(m1.point_data["damage"]) >= a.threshold) & (np.asarray(m0.point_data["damage"]) < a.threshold)
    size = float(np.max(np.ptp(ref, axis=0)))
    radius = a.radius or size / 5.0
    z = ref[:, 2]
    slabs = [("", np.ones(len(ref), dtype=bool))]
    if a.slabs > 1:
        # Through the thickness of a 3D plate: the same fit in each of K slabs of z.
        edges = np.linspace(z.min(), z.max(), a.slabs + 1)
        edges[-1] = np.nextafter(edges[-1], np.inf)
        slabs += [(f" [z {edges[k]:.4g}..{min(edges[k + 1], z.max()):.4g} m]", (z >= edges[k]) & (z < edges[k + 1]))
                  for k in range(a.slabs)]
    for tip_s in a.tip:
        parts = [float(v) for v in tip_s.split(",")]
        side = parts[2] if len(parts) > 2 else 0.0
        tip = np.array(parts[:2] + [0.0])
        # In the plate's plane: a 3D plate's nodes at every depth count alike.
        dist = np.linalg.norm((ref - tip)[:, :2], axis=1)
        near = new & (dist <= radius) & (dist >= a.r0)
        if side != 0.0:
            near &= (ref[:, 1] - tip[1]) * side > 0
        if a.ahead:
            near &= ref[:, 0] > tip[0]
        for label, inslab in slabs:
            pts = ref[near & inslab]
            if len(pts) < 3:
                print(f"crack_angle: tip {tip_s}{label}: no crack grew (fewer than 3 new damaged nodes within {radius:.3e} m)")
                continue
            off = pts - tip
            # Direction: principal axis of the offsets in the plane (from the tip, or from
            # their centroid with --from), oriented away from the tip.
            centre = off.mean(axis=0) if a.r0 > 0 else np.zeros(3)
            u, s, vt = np.linalg.svd(off[:, :2] - centre[:2], full_matrices=False)
            d = vt[0]
            if np.dot(off[:, :2].mean(axis=0), d) < 0:
                d = -d
            angle = math.degrees(math.atan2(d[1], d[0]))
            print(f"crack_angle: tip {tip_s}{label}: {angle:+.1f} degrees from the notch line ({len(pts)} new damaged nodes)")

if __name__ == "__main__":
    main()
