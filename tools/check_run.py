#!/usr/bin/env python3
"""Cross-check the output of a `hooke run` that wrote both formats (output.format = ["vtk", "hdf5"]).

    python3 tools/check_run.py OUTDIR

Reads every frame of the VTK series with meshio and pyvista, and of the HDF5 series with h5py and
meshio's XDMF TimeSeriesReader, and checks that the two independent writers agree exactly: the
same times, point counts and point data. Prints 'N passed, M failed'; exits non-zero on failure.
"""
from checks import Checks
import glob
import os
import sys

import h5py
import meshio
import numpy as np
import pyvista as pv

from hooke_output import frames

FIELDS = ["displacement", "velocity", "damage", "pool_ratio", "strain_energy_density", "stress", "node_volume", "node_id", "region"]


def main(outdir):
    check = Checks("check_run")

    vtk = frames(outdir)
    xdmf = glob.glob(os.path.join(outdir, "*.xdmf"))
    check(len(xdmf) == 1, f"{outdir}: expected one .xdmf")
    with meshio.xdmf.TimeSeriesReader(xdmf[0]) as reader:
        points, _ = reader.read_points_cells()
        check(reader.num_steps == len(vtk), f"{reader.num_steps} XDMF steps vs {len(vtk)} VTK frames")
        h5 = h5py.File(xdmf[0].replace(".xdmf", ".h5"), "r")
        check(h5["mesh/points"].shape == points.shape, "h5py: mesh shape")
        for k, (t, path) in enumerate(vtk):
            tx, pd, _ = reader.read_data(k)
            m = meshio.read(path)
            pvm = pv.read(path)
            check(tx == t, f"frame {k}: XDMF time {tx} vs VTK {t}")
            check(len(m.points) == len(points) == pvm.n_points, f"frame {k}: point counts {len(m.points)}, {len(points)}, {pvm.n_points}")
            ref = np.asarray(m.points) - m.point_data["displacement"]
            # VTK stores current positions X + u: (X + u) - u recovers X only to rounding.
            check(np.allclose(ref, points, rtol=0.0, atol=1e-12 * np.abs(points).max()), f"frame {k}: reference positions differ")
            # A body of several materials carries each node's phase too.
            for name in FIELDS + (["material"] if "material" in m.point_data else []):
                a = m.point_data[name].reshape(len(points), -1)
                b = pd[name].reshape(len(points), -1)
                c = np.asarray(pvm.point_data[name]).reshape(len(points), -1)
                check(np.array_equal(a, b) and np.array_equal(a, c), f"frame {k}: {name} differs between VTK and HDF5")
            group = sorted(h5["frames"].keys())[k]
            check(np.array_equal(h5["frames"][group]["displacement"][()], m.point_data["displacement"]), f"frame {k}: h5py displacement")
            # The same geometry convention: each frame's geometry is its current positions.
            check(np.array_equal(h5["frames"][group]["points"][()], np.asarray(m.points)), f"frame {k}: HDF5 frame points differ from the VTK points")
    return check.finish()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1]))
