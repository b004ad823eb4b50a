#!/usr/bin/env python3
"""Crack map of a 2D hooke run: the damaged nodes at their reference positions, at chosen times.

    python3 tools/crack_map.py OUTDIR [--times T1,T2,...] [--threshold 0.2] [--out PNG] [--dpi 80]

One panel per time (the frame nearest to it; default: a third, two thirds and the end of
the run). Intact nodes are drawn faintly, nodes with damage >= threshold coloured by damage, so
crack paths stay readable at any resolution (a damage colour map over every node hides them
once there are more nodes than pixels). Axes in mm. Writes OUTDIR/crack_map.png unless --out
is given.
"""
import argparse
import os

import matplotlib
import numpy as np

from hooke_output import frame_near, frames, read

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outdir")
    ap.add_argument("--times")
    ap.add_argument("--threshold", type=float, default=0.2)
    ap.add_argument("--out")
    ap.add_argument("--dpi", type=int, default=80)
    a = ap.parse_args()
    fs = frames(a.outdir)
    if a.times:
        picks = [frame_near(fs, float(v)) for v in a.times.split(",")]
    else:
        n = len(fs)
        picks = [fs[max(n // 3, 0)], fs[max(2 * n // 3, 0)], fs[-1]]
    fig, axs = plt.subplots(1, len(picks), figsize=(5 * len(picks), 6), squeeze=False)
    for ax, (t, path) in zip(axs[0], picks):
        m = read(path)
        if "damage" not in m.point_data:
            raise SystemExit(f"{path}: no damage field (the case has no fracture)")
        ref = (np.asarray(m.points) - np.asarray(m.point_data["displacement"])) * 1e3
        if np.ptp(ref[:, 2]) != 0.0:
            raise SystemExit(f"{path}: a 3D run; crack_map draws 2D runs (use render_damage.py)")
        d = np.asarray(m.point_data["damage"])
        hit = d >= a.threshold
        ax.scatter(ref[~hit, 0], ref[~hit, 1], s=0.2, c="0.85", linewidths=0)
        sc = ax.scatter(ref[hit, 0], ref[hit, 1], s=2, c=d[hit], cmap="inferno_r", vmin=0, vmax=1, linewidths=0)
        ax.set_aspect("equal")
        ax.set_title(f"t = {t * 1e6:.1f} us")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
    fig.colorbar(sc, ax=axs[0].tolist(), shrink=0.6, label="damage")
    out = a.out or os.path.join(a.outdir, "crack_map.png")
    fig.savefig(out, dpi=a.dpi)
    print(f"crack_map: wrote {out} ({len(picks)} panels)")


if __name__ == "__main__":
    main()
