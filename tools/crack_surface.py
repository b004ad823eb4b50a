#!/usr/bin/env python3
"""The crack surface of a 3D hooke run, rendered off-screen with pyvista.

    python3 tools/crack_surface.py OUTDIR [--time T] [--level 0.2] [--cell H] [--out PNG] [--stl FILE]

The damage of the frame nearest to T (default: the last), minus what was damaged in the first
frame (notches, pre-cracks), is interpolated from the nodes onto a uniform grid of cell H
(default: 1.5 times the median node spacing) with a Gaussian kernel of that width, and the
surface where it crosses LEVEL is extracted (marching cubes): a crack shows as a thin sheet
(the two faces of the damaged band, clipped to the body) through the damaged nodes, its
wrinkles those of the crack front through the thickness. The
picture shows that surface coloured by depth (z) inside the body's outline, from an oblique
view and from +z; prints the surface's area and its extent. --stl also writes the surface.
"""
import argparse
import os

import numpy as np
import pyvista as pv

from hooke_output import frame_near, frames, read

pv.OFF_SCREEN = True


def crack_surface(ref, damage, level, cell):
    """The LEVEL isosurface of `damage` (per node at reference positions `ref`) on a grid of
    cell `cell`; None when nothing reaches the level."""
    if not np.any(damage >= level):
        return None
    lo, hi = ref.min(axis=0) - 2 * cell, ref.max(axis=0) + 2 * cell
    dims = np.maximum(np.ceil((hi - lo) / cell).astype(int) + 1, 2)
    grid = pv.ImageData(dimensions=dims, spacing=(cell, cell, cell), origin=lo)
    cloud = pv.PolyData(ref)
    cloud["damage"] = damage
    # Gaussian-weighted mean of the nodes within 2 cells: a smooth field whose level set is the
    # mid-surface of the damaged band.
    field = grid.interpolate(cloud, sharpness=2.0, radius=2.0 * cell, strategy="null_value", null_value=0.0)
    surf = field.contour([level], scalars="damage")
    if surf.n_points == 0:
        return None
    # Within the body: the kernel smears the band past its faces.
    lo, hi = ref.min(axis=0), ref.max(axis=0)
    surf = surf.clip_box([lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]], invert=False)
    return surf if surf.n_points > 0 else None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outdir")
    ap.add_argument("--time", type=float)
    ap.add_argument("--level", type=float, default=0.2)
    ap.add_argument("--cell", type=float)
    ap.add_argument("--out")
    ap.add_argument("--stl")
    a = ap.parse_args()
    fs = frames(a.outdir)
    t, path = fs[-1] if a.time is None else frame_near(fs, a.time)
    m0, m1 = read(fs[0][1]), read(path)
    ref = np.asarray(m1.points) - np.asarray(m1.point_data["displacement"])
    if np.ptp(ref[:, 2]) == 0.0:
        raise SystemExit(f"{a.outdir}: a 2D run; use render_damage.py or crack_map.py")
    d0 = np.asarray(m0.point_data["damage"])
    d1 = np.asarray(m1.point_data["damage"])
    # Only what the run broke: the damage gained since the first frame.
    grown = np.clip(d1 - d0, 0.0, 1.0)
    if a.cell is None:
        # 1.5 times the median nearest-neighbour distance of a sample of nodes.
        sample = ref[:: max(1, len(ref) // 2000)]
        cloud = pv.PolyData(ref)
        d = [np.linalg.norm(ref[cloud.find_closest_point(p, n=2)[1]] - p) for p in sample]
        a.cell = 1.5 * float(np.median(d))
    surf = crack_surface(ref, grown, a.level, a.cell)
    if surf is None:
        print(f"crack_surface: t = {t:.6e} s: no crack (no grown damage reaches {a.level})")
        return 1
    lo, hi = surf.bounds[0::2], surf.bounds[1::2]
    print(f"crack_surface: t = {t:.6e} s, cell {a.cell:.3e} m: area {surf.area:.4e} m^2, "
          f"x {lo[0]:.4g}..{hi[0]:.4g}, y {lo[1]:.4g}..{hi[1]:.4g}, z {lo[2]:.4g}..{hi[2]:.4g} m")
    if a.stl:
        surf.extract_surface().triangulate().save(a.stl)
    out = a.out or os.path.join(a.outdir, "crack_surface.png")
    outline = pv.PolyData(ref).outline()
    p = pv.Plotter(shape=(1, 2), window_size=(1600, 700))
    for k, view in enumerate(["iso", "xy"]):
        p.subplot(0, k)
        p.add_mesh(outline, color="black")
        p.add_mesh(surf, scalars=surf.points[:, 2], cmap="viridis", scalar_bar_args={"title": "z (m)"})
        p.add_text(f"crack surface, t = {t * 1e6:.1f} us" if k == 0 else "seen from +z", font_size=10)
        if view == "iso":
            p.view_isometric()
        else:
            p.view_xy()
    p.screenshot(out)
    p.close()
    print(f"crack_surface: wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
