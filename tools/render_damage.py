#!/usr/bin/env python3
"""Render the damage field of every frame (or every K-th) of a hooke run to PNG, off-screen.

    python3 tools/render_damage.py OUTDIR [--every K] [--size 1200x800]

Writes OUTDIR/png/damage_STEP.png: the nodes at their current positions, coloured by damage
(0 intact, 1 all springs broken). 2D runs are seen from +z, 3D runs from an oblique view.
"""
import argparse
import os

import numpy as np
import pyvista as pv

from hooke_output import frames, read

pv.OFF_SCREEN = True


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outdir")
    ap.add_argument("--every", type=int, default=1)
    ap.add_argument("--size", default="1200x800")
    a = ap.parse_args()
    w, h = (int(v) for v in a.size.split("x"))
    os.makedirs(os.path.join(a.outdir, "png"), exist_ok=True)
    written = 0
    for k, (t, path) in enumerate(frames(a.outdir)):
        if k % a.every:
            continue
        mesh = read(path)
        if "damage" not in mesh.point_data:
            raise SystemExit(f"{path}: no damage field (the case has no fracture)")
        flat = np.ptp(np.asarray(mesh.points)[:, 2]) == 0.0
        p = pv.Plotter(off_screen=True, window_size=(w, h))
        cloud = pv.PolyData(np.asarray(mesh.points))
        cloud.point_data["damage"] = np.asarray(mesh.point_data["damage"])
        p.add_mesh(cloud, scalars="damage", cmap="inferno", clim=(0.0, 1.0), point_size=4, render_points_as_spheres=True)
        p.add_text(f"t = {t * 1e6:.2f} us", font_size=12)
        if flat:
            p.view_xy()
        else:
            p.view_isometric()
        name = os.path.join(a.outdir, "png", "damage_" + os.path.basename(path).rsplit("_", 1)[-1].replace(".vtu", ".png"))
        p.screenshot(name)
        p.close()
        written += 1
    print(f"render_damage: wrote {written} images to {os.path.join(a.outdir, 'png')}")


if __name__ == "__main__":
    main()
