#!/usr/bin/env python3
"""Tests of the post-processing tools on synthetic runs with a known answer.

    python3 tools/test_tools.py

A two-frame series is written with meshio: a square of nodes with a notch along x ending at
(0.5, 0.5), and in the second frame a crack of length 0.3 at +70 degrees from the notch tip,
grown in 1e-5 s. crack_angle must find 70 degrees, crack_tip a growth of about 0.3 and a speed
of about 0.3/1e-5; render_damage and energy_plot must write their images. Prints 'N passed,
M failed'; exits non-zero on any failure.
"""
from checks import Checks
import math
import os
import subprocess
import sys
import tempfile

import meshio
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def synthetic_y(outdir):
    """A crack along the notch line from (0.5, 0.5) to (0.7, 0.5) that branches there into two
    cracks at +25 and -20 degrees, 0.25 long; written in a second frame, 1e-5 s later."""
    n = 161
    xs, ys = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    pts = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(n * n)])
    h = 1.0 / (n - 1)
    notch = (np.abs(pts[:, 1] - 0.5) < 0.6 * h) & (pts[:, 0] <= 0.5 + 1e-9)
    stem = (pts[:, 0] > 0.5) & (pts[:, 0] <= 0.7) & (np.abs(pts[:, 1] - 0.5) < 0.6 * h)
    dmg = notch | stem
    for deg in (25.0, -20.0):
        a = math.radians(deg)
        rel = pts[:, :2] - [0.7, 0.5]
        along = rel @ [math.cos(a), math.sin(a)]
        dmg |= (along > 0) & (along <= 0.25) & (np.abs(rel @ [-math.sin(a), math.cos(a)]) < 0.6 * h)
    names = []
    for k, (t, d) in enumerate([(0.0, notch), (1e-5, dmg)]):
        name = f"y_{k:06}.vtu"
        meshio.Mesh(pts, [("vertex", np.arange(n * n).reshape(-1, 1))],
                    point_data={"damage": d.astype(float), "displacement": np.zeros((n * n, 3))}).write(os.path.join(outdir, name))
        names.append((t, name))
    with open(os.path.join(outdir, "y.pvd"), "w") as f:
        f.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n<Collection>\n')
        for t, name in names:
            f.write(f'<DataSet timestep="{t:.17e}" group="" part="0" file="{name}"/>\n')
        f.write("</Collection>\n</VTKFile>\n")


def synthetic(outdir, branch=False, kink=False, edge=False):
    n = 81
    xs, ys = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    pts = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(n * n)])
    h = 1.0 / (n - 1)
    notch = (np.abs(pts[:, 1] - 0.5) < 0.6 * h) & (pts[:, 0] <= 0.5 + 1e-9)
    a = math.radians(70.0)
    rel = pts[:, :2] - [0.5, 0.5]
    along = rel @ [math.cos(a), math.sin(a)]
    across = np.abs(rel @ [-math.sin(a), math.cos(a)])
    crack = (along > 0) & (along <= 0.3) & (across < 0.6 * h)
    if kink:
        # The crack first runs 0.05 along the notch line, then turns to 70 degrees.
        k0 = np.array([0.55, 0.5])
        rel_k = pts[:, :2] - k0
        along_k = rel_k @ [math.cos(a), math.sin(a)]
        across_k = np.abs(rel_k @ [-math.sin(a), math.cos(a)])
        first = (rel[:, 0] > 0) & (rel[:, 0] <= 0.05) & (np.abs(rel[:, 1]) < 0.6 * h)
        crack = first | ((along_k > 0) & (along_k <= 0.3) & (across_k < 0.6 * h))
    # A later frame (with branch=True) adds a branch along the notch line: --time must see past it.
    flat = (rel[:, 0] > 0) & (rel[:, 0] <= 0.3) & (np.abs(rel[:, 1]) < 0.6 * h)
    states = [(0.0, notch), (1e-5, notch | crack)]
    if branch:
        far = (pts[:, 0] > 1.0 - 0.6 * h) & (np.abs(pts[:, 1] - 0.2) < 0.6 * h) if edge else np.zeros(n * n, bool)
        states.append((2e-5, notch | crack | flat | far))
    files = []
    for k, (t, dmg) in enumerate(states):
        name = f"run_{k:06}.vtu"
        m = meshio.Mesh(pts, [("vertex", np.arange(n * n).reshape(-1, 1))],
                        point_data={"damage": dmg.astype(float), "displacement": np.zeros((n * n, 3))})
        m.write(os.path.join(outdir, name))
        files.append((t, name))
    with open(os.path.join(outdir, "run.pvd"), "w") as f:
        f.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n<Collection>\n')
        for t, name in files:
            f.write(f'<DataSet timestep="{t:.17e}" group="" part="0" file="{name}"/>\n')
        f.write("</Collection>\n</VTKFile>\n")
    with open(os.path.join(outdir, "run_energy.csv"), "w") as f:
        f.write("time,kinetic,strain_direct,strain_dispersive,external_work,boundary_work,body_work,dissipated,released,balance_error\n")
        f.write("0,0,0,0,0,0,0,0,0,0\n1e-5,1,2,0.5,0,4,0,0,0.5,0\n")


def synthetic_3d(outdir, angles):
    """A plate of len(angles) layers in z (0, 0.01, ...), the notch through all of them and a
    crack of length 0.3 at angles[k] degrees in layer k: a crack front that twists."""
    n = 41
    xs, ys = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    h = 1.0 / (n - 1)
    layers, before, after = [], [], []
    for k, deg in enumerate(angles):
        pts = np.column_stack([xs.ravel(), ys.ravel(), np.full(n * n, 0.01 * k)])
        notch = (np.abs(pts[:, 1] - 0.5) < 0.6 * h) & (pts[:, 0] <= 0.5 + 1e-9)
        a = math.radians(deg)
        rel = pts[:, :2] - [0.5, 0.5]
        along = rel @ [math.cos(a), math.sin(a)]
        across = np.abs(rel @ [-math.sin(a), math.cos(a)])
        crack = (along > 0) & (along <= 0.3) & (across < 0.6 * h)
        layers.append(pts)
        before.append(notch)
        after.append(notch | crack)
    pts = np.vstack(layers)
    with open(os.path.join(outdir, "run.pvd"), "w") as f:
        f.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n<Collection>\n')
        for k, (t, dmg) in enumerate([(0.0, np.concatenate(before)), (1e-5, np.concatenate(after))]):
            name = f"run_{k:06}.vtu"
            meshio.Mesh(pts, [("vertex", np.arange(len(pts)).reshape(-1, 1))],
                        point_data={"damage": dmg.astype(float), "displacement": np.zeros((len(pts), 3))}
                        ).write(os.path.join(outdir, name))
            f.write(f'<DataSet timestep="{t:.17e}" group="" part="0" file="{name}"/>\n')
        f.write("</Collection>\n</VTKFile>\n")


def largest(out):
    """The largest speed crack_tip.py printed (m/s), or nan."""
    try:
        return float(out.split("largest speed ")[1].split(" ")[0])
    except (IndexError, ValueError):
        return float("nan")


def run(*args):
    r = subprocess.run([sys.executable, *args], capture_output=True, text=True)
    return r.returncode, r.stdout + r.stderr


def main():
    check = Checks("test_tools")

    with tempfile.TemporaryDirectory() as d:
        synthetic(d)
        code, out = run(os.path.join(HERE, "crack_angle.py"), d, "--tip", "0.5,0.5", "--radius", "0.4")
        angle = float(out.split("tip 0.5,0.5: ")[1].split(" degrees")[0]) if "degrees" in out else float("nan")
        check(code == 0 and abs(angle - 70.0) < 2.0, f"crack_angle: {out.strip()}")
        code, out = run(os.path.join(HERE, "crack_tip.py"), d, "--origin", "0.5,0.5")
        check(code == 0 and abs(largest(out) - 3e4) < 2e3, f"crack_tip largest speed: {out.strip()}")
        rows = np.loadtxt(os.path.join(d, "crack_tip.csv"), delimiter=",", skiprows=1)
        check(code == 0 and abs(rows[-1, 4] - 0.3) < 0.02, f"crack_tip growth: {out.strip()}")
        check(abs(rows[-1, 5] - 0.3 / 1e-5) < 0.02 / 1e-5, f"crack_tip speed: {rows[-1, 5]}")
        code, out = run(os.path.join(HERE, "render_damage.py"), d)
        check(code == 0 and os.path.getsize(os.path.join(d, "png", "damage_000001.png")) > 1000, f"render_damage: {out.strip()[-300:]}")
        code, out = run(os.path.join(HERE, "energy_plot.py"), d)
        check(code == 0 and os.path.getsize(os.path.join(d, "energy.png")) > 1000, f"energy_plot: {out.strip()}")
        code, out = run(os.path.join(HERE, "crack_map.py"), d, "--times", "0,1e-5")
        check(code == 0 and os.path.getsize(os.path.join(d, "crack_map.png")) > 1000, f"crack_map: {out.strip()}")
    with tempfile.TemporaryDirectory() as d:
        # Through the thickness: the angle per slab of a 3D plate, and over all of it.
        synthetic_3d(d, [60.0, 70.0, 80.0])
        code, out = run(os.path.join(HERE, "crack_angle.py"), d, "--tip", "0.5,0.5", "--radius", "0.4", "--slabs", "3")
        found = [float(line.split(": ")[-1].split(" degrees")[0]) for line in out.splitlines() if "degrees" in line]
        check(code == 0 and len(found) == 4 and all(abs(f - e) < 2.0 for f, e in zip(found[1:], [60.0, 70.0, 80.0]))
              and abs(found[0] - 70.0) < 3.0, f"crack_angle --slabs: {out.strip()}")
        # The crack surface: a sheet through the grown damage (not the notch), inside the body,
        # reaching about as far as the crack (0.3 from the tip at 60 to 80 degrees: y up to 0.8).
        png = os.path.join(d, "surface.png")
        code, out = run(os.path.join(HERE, "crack_surface.py"), d, "--out", png, "--cell", "0.025")
        ok = code == 0 and os.path.getsize(png) > 1000 and "area" in out
        if ok:
            ys = out.split(" y ")[1].split(",")[0].split("..")
            ok = 0.45 < float(ys[0]) < 0.55 and 0.72 < float(ys[1]) < 0.85
        check(ok, f"crack_surface: {out.strip()[-400:]}")
    with tempfile.TemporaryDirectory() as d:
        synthetic(d, branch=True)
        code, out = run(os.path.join(HERE, "crack_angle.py"), d, "--tip", "0.5,0.5", "--radius", "0.4", "--time", "0.9e-5")
        angle = float(out.split("tip 0.5,0.5: ")[1].split(" degrees")[0]) if "degrees" in out else float("nan")
        check(code == 0 and abs(angle - 70.0) < 2.0, f"crack_angle --time: {out.strip()}")
        code, out = run(os.path.join(HERE, "crack_angle.py"), d, "--tip", "0.5,0.5", "--radius", "0.4")
        angle = float(out.split("tip 0.5,0.5: ")[1].split(" degrees")[0]) if "degrees" in out else float("nan")
        check(code == 0 and abs(angle - 70.0) > 10.0, f"crack_angle sees the later branch without --time: {out.strip()}")
        code, out = run(os.path.join(HERE, "crack_angle.py"), d, "--tip", "0.5,0.5", "--radius", "0.4", "--time", "1.1e-5")
        check(code == 0 and "t = 1.000000e-05 s" in out, f"crack_angle --time picks the nearest frame: {out.strip()}")
    with tempfile.TemporaryDirectory() as d:
        # A later frame adds damage at the far boundary (the last ligament failing): not a tip.
        synthetic(d, branch=True, edge=True)
        code, out = run(os.path.join(HERE, "crack_tip.py"), d, "--origin", "0.5,0.5")
        check(code == 0 and abs(largest(out) - 3e4) < 2e3 and "reached the boundary" in out,
              f"crack_tip stops at the boundary: {out.strip()}")
    with tempfile.TemporaryDirectory() as d:
        synthetic(d, kink=True)
        code, out = run(os.path.join(HERE, "crack_angle.py"), d, "--tip", "0.5,0.5", "--radius", "0.4", "--from", "0.12")
        angle = float(out.split("tip 0.5,0.5: ")[1].split(" degrees")[0]) if "degrees" in out else float("nan")
        check(code == 0 and abs(angle - 70.0) < 2.0, f"crack_angle --from past a first straight stretch: {out.strip()}")
        code, out = run(os.path.join(HERE, "crack_angle.py"), d, "--tip", "0.5,0.5", "--radius", "0.4")
        angle = float(out.split("tip 0.5,0.5: ")[1].split(" degrees")[0]) if "degrees" in out else float("nan")
        check(code == 0 and angle < 65.0, f"crack_angle through the tip averages the straight stretch in: {out.strip()}")
    with tempfile.TemporaryDirectory() as d:
        # A Y-shaped crack: the branching point (0.7, 0.5) and the two directions.
        synthetic_y(d)
        code, out = run(os.path.join(HERE, "crack_branch.py"), d)
        ok = code == 0 and "branches at x" in out
        if ok:
            line = out.split("branches at x = ")[1]
            xb = float(line.split(" m")[0])
            angles = [float(v) for v in line.split("branches at ")[1].split(" degrees")[0].split(" and ")]
            ok = abs(xb - 0.7) < 0.02 and abs(angles[0] - 25.0) < 3.0 and abs(angles[1] + 20.0) < 3.0
        check(ok, f"crack_branch: {out.strip()}")
        os.makedirs(d + "/straight")
        synthetic(d + "/straight")
        code, out = run(os.path.join(HERE, "crack_branch.py"), d + "/straight")
        check(code == 0 and "no branching" in out, f"crack_branch on one crack: {out.strip()}")
    with tempfile.TemporaryDirectory() as d:
        # A grip pulled along +y with a known peak, and a rigid platen moving along -y.
        with open(os.path.join(d, "c_reactions.csv"), "w") as f:
            f.write("# comment\ntime,region,name,force_x,force_y,force_z,displacement_x,displacement_y,displacement_z\n")
            for k in range(11):
                u = 1e-5 * k
                load = 2e3 * min(k, 10 - k)  # peak 1e4 N at k = 5
                f.write(f"{k},0,grip,0,{load},0,0,{u},0\n{k},1,base,0,{-load},0,0,0,0\n")
        with open(os.path.join(d, "c_contact.csv"), "w") as f:
            f.write("time,body,name,reaction_x,reaction_y,reaction_z,x,y,z,vx,vy,vz,wx,wy,wz,qw,qx,qy,qz,torque_x,torque_y,torque_z\n")
            for k in range(5):
                f.write(f"{k},0,platen,0,{300.0 * k},0,0,{0.1 - 1e-4 * k},0,0,-1,0,0,0,0,1,0,0,0,0,0,0\n")
        code, out = run(os.path.join(HERE, "load_displacement.py"), d)
        check(code == 0 and "grip: peak 1.0000e+04 N at 0.0500 mm" in out and "base" not in out, f"load_displacement regions: {out.strip()}")
        check("platen: peak 1.2000e+03 N at 0.4000 mm" in out, f"load_displacement rigid bodies: {out.strip()}")
        check(os.path.getsize(os.path.join(d, "load_displacement.png")) > 1000, "load_displacement: no picture")
        code, out = run(os.path.join(HERE, "load_displacement.py"), d, "--region", "nope")
        check(code != 0 and "there are" in out, f"load_displacement names what exists: {out.strip()}")
    return check.finish()


if __name__ == "__main__":
    sys.exit(main())
