"""Open hooke output with ParaView itself (run with pvpython or pvbatch).

    pvpython tools/check_paraview.py OUTDIR

Opens the .pvd series (ParaView's PVD reader) and, when present, the .xdmf series (its XDMF3
reader), and checks the number of points, time steps and arrays against OUTDIR/manifest.json.
Prints 'N passed, M failed'; exits non-zero on any failure.
"""
from checks import Checks
import json
import os
import sys

from paraview import servermanager as sm
from paraview.simple import OpenDataFile, UpdatePipeline


def main(outdir):
    man = json.load(open(os.path.join(outdir, "manifest.json")))
    check = Checks("check_paraview")

    files = [man["pvd"]] + ([man["xdmf"]] if man.get("xdmf") else [])
    for name in files:
        r = OpenDataFile(os.path.join(outdir, name))
        check(r is not None, f"ParaView cannot open {name}")
        if r is None:
            continue
        r.UpdatePipelineInformation()
        times = list(r.TimestepValues) if hasattr(r.TimestepValues, "__len__") else [r.TimestepValues]
        check(len(times) == len(man["frames"]), f"{name}: {len(times)} time steps, expected {len(man['frames'])}")
        # The first update of a fresh reader can report an empty output in pvpython; prime it.
        UpdatePipeline(time=times[-1], proxy=r)
        for t in times:
            UpdatePipeline(time=t, proxy=r)
            npts = r.GetDataInformation().GetNumberOfPoints()
            check(npts == man["points"], f"{name} at t = {t}: {npts} points, expected {man['points']}")
        arrays = [r.PointData.GetArray(i).GetName() for i in range(len(r.PointData))]
        for field in ["displacement", "velocity", "damage", "stress"]:
            check(field in arrays, f"{name}: no point array {field} (has {arrays})")
        rng = r.PointData["damage"].GetRange()
        check(abs(rng[1] - man["frames"][-1]["damage_max"]) < 1e-12, f"{name}: damage max {rng[1]}")
    return check.finish()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1]))
