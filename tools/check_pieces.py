#!/usr/bin/env python3
"""Check the frames of a run written in pieces by several MPI ranks against a one-process run.

    python3 tools/check_pieces.py ALONE PIECES

pyvista (VTK's own .pvtu reader) must read every .pvtu of PIECES as one dataset whose points
and arrays equal, bit for bit, the one-process run's frame at the same time (nodes in node_id
order). Writes PIECES/manifest.json, which `pvpython tools/check_paraview.py PIECES` reads to
open the series in ParaView itself. meshio reads the pieces one by one (tools/compare_runs.py).
Prints 'N passed, M failed'; exits non-zero on any failure.
"""
import json
import os
import sys

import numpy as np
import pyvista as pv

from checks import Checks
from hooke_output import frames, pvd_of


def main(alone, pieces):
    check = Checks("check_pieces")
    fa, fb = frames(alone), frames(pieces)
    check(len(fa) == len(fb) and len(fb) > 0, f"{len(fa)} frames vs {len(fb)}")
    manifest = {"pvd": os.path.basename(pvd_of(pieces)), "frames": [], "points": 0}
    for (ta, pa), (tb, pb) in zip(fa, fb):
        check(ta == tb, f"frame times {ta} vs {tb}")
        check(pb.endswith(".pvtu"), f"{pb}: not a .pvtu")
        a, b = pv.read(pa), pv.read(pb)
        check(a.n_points == b.n_points, f"{os.path.basename(pb)}: {b.n_points} points, expected {a.n_points}")
        ib = np.argsort(np.asarray(b.point_data["node_id"]).ravel())
        check(np.array_equal(np.asarray(b.point_data["node_id"])[ib], np.arange(a.n_points)),
              f"{os.path.basename(pb)}: node ids are not 0..n-1")
        check(np.array_equal(a.points, b.points[ib]), f"{os.path.basename(pb)}: points differ")
        for name in a.point_data.keys():
            x, y = np.asarray(a.point_data[name]), np.asarray(b.point_data[name])[ib]
            check(x.dtype == y.dtype and np.array_equal(x.view(np.uint8), y.view(np.uint8)),
                  f"{os.path.basename(pb)}: {name} differs")
        manifest["points"] = int(b.n_points)
        damage = float(np.max(b.point_data["damage"])) if "damage" in b.point_data else 0.0
        manifest["frames"].append({"time": tb, "damage_max": damage})
    json.dump(manifest, open(os.path.join(pieces, "manifest.json"), "w"))
    return check.finish()


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2]))
