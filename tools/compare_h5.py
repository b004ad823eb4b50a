#!/usr/bin/env python3
"""Compare two HDF5 outputs of hooke bit for bit: the same datasets, shapes, types and values
(floating-point values compared as bits, so NaN and -0.0 count).

Usage: tools/compare_h5.py A.h5 B.h5   (exit 1 on any difference)
"""
import sys

import h5py
import numpy as np


def datasets(f):
    names = []
    f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
    return sorted(names)


def same(x, y):
    if x.shape != y.shape or x.dtype != y.dtype:
        return False
    if x.dtype.kind == "f":
        bits = np.dtype(f"u{x.dtype.itemsize}")
        return np.array_equal(np.ascontiguousarray(x).view(bits), np.ascontiguousarray(y).view(bits))
    return np.array_equal(x, y)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    with h5py.File(sys.argv[1], "r") as a, h5py.File(sys.argv[2], "r") as b:
        na, nb = datasets(a), datasets(b)
        if na != nb:
            print(f"compare_h5: the files hold different datasets: {sorted(set(na) ^ set(nb))[:10]}")
            sys.exit(1)
        bad = [n for n in na if not same(a[n][()], b[n][()])]
        for n in bad[:10]:
            print(f"compare_h5: {n} differs")
        print(f"compare_h5: {len(na) - len(bad)} datasets identical, {len(bad)} differ")
        sys.exit(1 if bad or not na else 0)


if __name__ == "__main__":
    main()
