#!/usr/bin/env python3
"""Crack map of a 2D hooke run: the damaged nodes at their reference positions, at chosen times.

    python3 tools/crack_map.py OUTDIR [--times T1,T2,...] [--threshold 0.2] [--out PNG] [--dpi 80]
                                      [--slice-z Z [--slab W]] [--marker 2]

One panel per time (the frame nearest to it; default: a third, two thirds and the end of
the run). Intact nodes are drawn faintly, nodes with damage >= threshold coloured by damage, so
crack paths stay readable at any resolution (a damage colour map over every node hides them
once there are more nodes than pixels). Axes in mm. Writes OUTDIR/crack_map.png unless --out
is given. A 3D run is drawn as the node plane nearest to z = Z (m) with --slice-z (a plate's
through-thickness crack, e.g. cases/fibre_notch.toml), or, on a random lattice, as the nodes within
--slab W (m) of it; without --slice-z, 3D runs are refused.
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
    ap.add_argument("--marker", type=float, default=2.0, help="marker size of damaged nodes (points^2)")
    ap.add_argument("--slice-z", type=float, help="3D runs: draw the node plane nearest to this z (m)")
    ap.add_argument(
        "--slab",
        type=float,
        help="with --slice-z on a random 3D lattice (no node planes): draw the nodes within this half-width (m) of Z",
    )
    a = ap.parse_args()
    fs = frames(a.outdir)
    if a.times:
        picks = [frame_near(fs, float(v)) for v in a.times.split(",")]
    else:
        n = len(fs)
        picks = [fs[max(n // 3, 0)], fs[max(2 * n // 3, 0)], fs[-1]]
    fig, axs = plt.subplots(1, len(picks), figsize=(4.2 * len(picks), 4.2), squeeze=False)
    for ax, (t, path) in zip(axs[0], picks):
        m = read(path)
        if "damage" not in m.point_data:
            raise SystemExit(f"{path}: no damage field (the case has no fracture)")
        ref = (np.asarray(m.points) - np.asarray(m.point_data["displacement"])) * 1e3
        d = np.asarray(m.point_data["damage"])
        if np.ptp(ref[:, 2]) != 0.0:
            if a.slice_z is None:
                raise SystemExit(
                    f"{path}: a 3D run; give --slice-z Z for one node plane (or use render_damage.py)"
                )
            z = ref[:, 2] / 1e3
            if a.slab is not None:
                plane = np.abs(z - a.slice_z) <= a.slab
            else:
                plane = np.abs(z - z[np.argmin(np.abs(z - a.slice_z))]) < 1e-12 + 1e-9 * np.ptp(z)
            ref, d = ref[plane], d[plane]
        hit = d >= a.threshold
        ax.scatter(ref[~hit, 0], ref[~hit, 1], s=0.2, c="0.85", linewidths=0)
        sc = ax.scatter(ref[hit, 0], ref[hit, 1], s=a.marker, c=d[hit], cmap="inferno_r", vmin=0, vmax=1, linewidths=0)
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
