"""Shared helpers for the post-processing tools: read a hooke run folder (.pvd series)."""
import glob
import os
import re

import numpy as np
import pyvista as pv


def pvd_of(outdir):
    """The .pvd collection of a run folder."""
    found = sorted(glob.glob(os.path.join(outdir, "*.pvd")))
    if not found:
        raise SystemExit(f"{outdir}: no .pvd file (is this the output folder of `hooke run`?)")
    return found[0]


def frames(outdir):
    """(time, file path) of every frame, in time order."""
    pvd = pvd_of(outdir)
    text = open(pvd).read()
    out = []
    for t, f in re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', text):
        out.append((float(t), os.path.join(os.path.dirname(pvd), f)))
    return sorted(out)


def frame_near(fs, t):
    """The frame of `fs` (from `frames`) whose time is nearest to `t`: frames are written at the
    first step at or after each output time, so a frame meant for t may carry a time just past
    it."""
    return min(fs, key=lambda f: abs(f[0] - t))


def read(path):
    """Points (reference + displacement are both available) and point data of one frame."""
    mesh = pv.read(path)
    return mesh


def damage_points(mesh, threshold):
    """Reference positions of the nodes whose damage is at least `threshold`."""
    d = np.asarray(mesh.point_data["damage"])
    ref = np.asarray(mesh.points) - np.asarray(mesh.point_data["displacement"])
    return ref[d >= threshold]
