#!/usr/bin/env python3
"""Compare two hooke output folders bit for bit.

    python3 tools/compare_runs.py A B [--ignore FIELD ...] [--node-order]

Every frame the two .pvd series list (same times, same files) is read with meshio (a .pvtu of a
run on several MPI ranks piece by piece, the pieces joined in order); every point
array both frames carry must be identical to the bit, as must the points. The energy, contact and
reaction histories (CSV) must be identical byte for byte where both runs wrote them. Arrays only
one run writes are listed, not failed (a newer hooke writes more fields). --ignore skips fields
whose definition changed on purpose. --node-order matches nodes by their `node_id` (frames
written by several processes list nodes in another order). Prints 'N passed, M failed'; exits
non-zero on any difference.
"""
import argparse
import glob
import os
import re
import sys

import meshio
import numpy as np

from checks import Checks
from hooke_output import frames


def read_frame(path):
    """A frame as one meshio mesh (points and point data): a .vtu, or the pieces a .pvtu lists
    (written by several MPI ranks), read one by one with meshio and joined in piece order."""
    if not path.endswith(".pvtu"):
        return meshio.read(path)
    text = open(path).read()
    pieces = [meshio.read(os.path.join(os.path.dirname(path), f))
              for f in re.findall(r'<Piece Source="([^"]+)"', text)]
    if not pieces:
        raise ValueError(f"{path} lists no pieces")
    points = np.concatenate([p.points for p in pieces])
    data = {k: np.concatenate([p.point_data[k] for p in pieces])
            for k in pieces[0].point_data}
    return meshio.Mesh(points, [("vertex", np.arange(len(points)).reshape(-1, 1))], point_data=data)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--ignore", nargs="*", default=[])
    ap.add_argument("--node-order", action="store_true")
    args = ap.parse_args()
    check = Checks("compare_runs")
    fa, fb = frames(args.a), frames(args.b)
    check(len(fa) == len(fb), f"{len(fa)} frames vs {len(fb)}")
    only = set()
    for (ta, pa), (tb, pb) in zip(fa, fb):
        check(ta == tb, f"frame times {ta} vs {tb}")
        ma, mb = read_frame(pa), read_frame(pb)
        ia = ib = slice(None)
        if args.node_order:
            ia = np.argsort(ma.point_data["node_id"].ravel())
            ib = np.argsort(mb.point_data["node_id"].ravel())
        check(np.array_equal(ma.points[ia], mb.points[ib]), f"{os.path.basename(pa)}: points differ")
        for name in sorted(set(ma.point_data) | set(mb.point_data)):
            if name in args.ignore:
                continue
            if name not in ma.point_data or name not in mb.point_data:
                only.add(name)
                continue
            a, b = ma.point_data[name][ia], mb.point_data[name][ib]
            same = a.shape == b.shape and np.array_equal(a.view(np.uint8), b.view(np.uint8)) if a.dtype == b.dtype else np.array_equal(a, b)
            check(same, f"{os.path.basename(pa)}: {name} differs")
    for pattern in ["*_energy.csv", "*_contact.csv", "*_reactions.csv"]:
        for pa in glob.glob(os.path.join(args.a, pattern)):
            pb = os.path.join(args.b, os.path.basename(pa))
            if os.path.exists(pb):
                check(open(pa, "rb").read() == open(pb, "rb").read(), f"{os.path.basename(pa)} differs")
    if only:
        print(f"compare_runs: arrays in one run only (not compared): {', '.join(sorted(only))}")
    return check.finish()


if __name__ == "__main__":
    sys.exit(main())
