#!/usr/bin/env python3
"""Check hooke's VTK output with real readers (meshio, and pyvista on top of VTK).

    python3 tools/check_output.py OUTDIR

OUTDIR holds a .pvd series and the manifest.json written with it (see
crates/io/examples/write_series.rs). Every frame is opened with meshio and, through the .pvd
collection, with pyvista; point counts, cell counts, array names and values must match the
manifest exactly (the files carry the f64 values bit for bit). Prints 'N passed, M failed' and
exits non-zero on any failure.
"""
from checks import Checks
import json
import math
import os
import sys

import meshio
import numpy as np
import pyvista as pv

FIELDS = ["displacement", "velocity", "damage", "pool_ratio", "strain_energy_density", "stress", "node_volume", "node_id"]


def main(outdir):
    man = json.load(open(os.path.join(outdir, "manifest.json")))
    npts = man["points"]
    check = Checks("check_output")

    def same(a, b):
        return a == b or (math.isfinite(a) and math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-300))

    # meshio, file by file
    for f in man["frames"]:
        m = meshio.read(os.path.join(outdir, f["file"]))
        check(len(m.points) == npts, f"meshio {f['file']}: {len(m.points)} points, expected {npts}")
        for name in FIELDS:
            check(name in m.point_data, f"meshio {f['file']}: no point data '{name}'")
        u = m.point_data["displacement"]
        check(same(float(u[0, 0]), f["ux_first"]) and same(float(u[-1, 0]), f["ux_last"]), f"meshio {f['file']}: displacement")
        check(same(float(m.point_data["velocity"][-1, 0]), f["vx_last"]), f"meshio {f['file']}: velocity")
        check(same(float(np.max(m.point_data["damage"])), f["damage_max"]), f"meshio {f['file']}: damage")
        nlines = sum(len(c.data) for c in m.cells if c.type == "line")
        check(nlines == f["lines"], f"meshio {f['file']}: {nlines} spring lines, expected {f['lines']}")
        check(m.point_data["stress"].shape == (npts, 9), f"meshio {f['file']}: stress shape {m.point_data['stress'].shape}")
        check(np.array_equal(m.point_data["node_id"].ravel(), np.arange(npts)), f"meshio {f['file']}: node_id is not 0..n-1")
        check(bool(np.all(m.point_data["node_volume"] > 0)), f"meshio {f['file']}: node_volume not positive")

    # pyvista (VTK's own readers), the whole series through the .pvd
    reader = pv.get_reader(os.path.join(outdir, man["pvd"]))
    times = reader.time_values
    check(len(times) == len(man["frames"]), f"pyvista: {len(times)} time steps, expected {len(man['frames'])}")
    for k, f in enumerate(man["frames"]):
        reader.set_active_time_value(times[k])
        check(same(float(times[k]), f["time"]), f"pyvista: time {times[k]} vs {f['time']}")
        mesh = reader.read()[0]
        check(mesh.n_points == npts, f"pyvista step {k}: {mesh.n_points} points")
        u = mesh.point_data["displacement"]
        check(same(float(u[-1, 0]), f["ux_last"]), f"pyvista step {k}: displacement")
        check(same(float(np.max(mesh.point_data["damage"])), f["damage_max"]), f"pyvista step {k}: damage")

    # HDF5 + XDMF (written when hooke-io is built with the hdf5 feature)
    if man.get("xdmf"):
        import h5py

        with h5py.File(os.path.join(outdir, man["xdmf"].replace(".xdmf", ".h5")), "r") as h5:
            check(h5["mesh/points"].shape == (npts, 3), "h5py: mesh/points shape")
            steps = sorted(h5["frames"].keys())
            check(len(steps) == len(man["frames"]), f"h5py: {len(steps)} frames")
            for s, f in zip(steps, man["frames"]):
                d = h5["frames"][s]["displacement"]
                check(d.compression == "gzip" and d.chunks is not None, f"h5py frame {s}: not chunked and compressed")
                check(same(float(d[0, 0]), f["ux_first"]) and same(float(d[-1, 0]), f["ux_last"]), f"h5py frame {s}: displacement")
                check(same(float(np.max(h5["frames"][s]["damage"][()])), f["damage_max"]), f"h5py frame {s}: damage")
        with meshio.xdmf.TimeSeriesReader(os.path.join(outdir, man["xdmf"])) as reader:
            points, cells = reader.read_points_cells()
            check(len(points) == npts, f"meshio xdmf: {len(points)} points")
            check(reader.num_steps == len(man["frames"]), f"meshio xdmf: {reader.num_steps} steps")
            for k, f in enumerate(man["frames"]):
                t, pd, _ = reader.read_data(k)
                check(same(t, f["time"]), f"meshio xdmf step {k}: time {t}")
                check(same(float(pd["displacement"][-1, 0]), f["ux_last"]), f"meshio xdmf step {k}: displacement")
                check(pd["stress"].shape == (npts, 9), f"meshio xdmf step {k}: stress shape")

    return check.finish()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1]))
