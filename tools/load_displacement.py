#!/usr/bin/env python3
"""Load-displacement curves of a hooke run, from its reaction and contact histories.

    python3 tools/load_displacement.py OUTDIR [--axis y] [--region NAME ...] [--body NAME ...]
                                             [--title TEXT] [--out PNG]
                                             [--reference N[:LABEL] ...] [--band LO,HI]

For every boundary region (CASE_reactions.csv: the force the region exerts on the body and its mean
displacement) and every rigid body (CASE_contact.csv: the force the lattice exerts on the body
and the body's position), plots the load along --axis against the displacement along it, in kN
and mm. Regions and bodies that do not move along the axis are left out unless named. Writes
OUTDIR/load_displacement.png and OUTDIR/load_displacement.csv (name, displacement in m, load in N;
the load as the specimen feels it: positive when the grip pulls along its motion) and prints each
curve's peak load.
"""
import argparse
import csv
import glob
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

AXES = {"x": 0, "y": 1, "z": 2}


def read_rows(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def curves(outdir, axis):
    """name -> (displacement m, load N) for regions and rigid bodies."""
    a = "xyz"[axis]
    out = {}
    for path in glob.glob(os.path.join(outdir, "*_reactions.csv")):
        by = {}
        for r in read_rows(path):
            by.setdefault(r["name"], []).append((float(r[f"displacement_{a}"]), float(r[f"force_{a}"])))
        for name, pts in by.items():
            d, f = np.array(pts).T
            # The region pushes the body with f; it is loaded in the direction it moves.
            sign = np.sign(d[np.argmax(np.abs(d))]) or 1.0
            out[name] = (d, sign * f)
    for path in glob.glob(os.path.join(outdir, "*_contact.csv")):
        by = {}
        for r in read_rows(path):
            by.setdefault(r["name"], []).append((float(r[a]), float(r[f"reaction_{a}"])))
        for name, pts in by.items():
            x, f = np.array(pts).T
            d = x - x[0]
            # `reaction` is the lattice's force on the body: it resists the body's motion.
            sign = np.sign(d[np.argmax(np.abs(d))]) or 1.0
            out[name] = (d, -sign * f)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir")
    ap.add_argument("--axis", default="y", choices=AXES)
    ap.add_argument("--region", nargs="*", default=None, help="boundary regions or rigid bodies to plot (default: all that move)")
    ap.add_argument("--body", nargs="*", default=None, help="same as --region")
    ap.add_argument("--title", default=None)
    ap.add_argument("--reference", action="append", default=[], metavar="N[:LABEL]",
                    help="a reference load (N) drawn as a horizontal line, e.g. an experiment's peak")
    ap.add_argument("--band", default=None, metavar="LO,HI",
                    help="a shaded load band (N), e.g. a tolerance around the reference")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    data = curves(args.outdir, AXES[args.axis])
    if not data:
        raise SystemExit(f"{args.outdir}: no *_reactions.csv or *_contact.csv (is this the output folder of `hooke run`?)")
    wanted = (args.region or []) + (args.body or [])
    missing = [w for w in wanted if w not in data]
    if missing:
        raise SystemExit(f"not in the histories: {', '.join(missing)}; there are: {', '.join(sorted(data))}")
    names = wanted or [n for n, (d, _) in data.items() if np.max(np.abs(d)) > 0]
    if not names:
        raise SystemExit(f"nothing moves along {args.axis}: name regions or bodies with --region")
    fig, ax = plt.subplots(figsize=(7, 5))
    rows = []
    for n in names:
        d, f = data[n]
        ax.plot(np.abs(d) * 1e3, f * 1e-3, label=n)
        k = int(np.argmax(f))
        print(f"load_displacement: {n}: peak {f[k]:.4e} N at {abs(d[k]) * 1e3:.4f} mm")
        rows += [(n, dd, ff) for dd, ff in zip(d, f)]
    for r in args.reference:
        load, _, label = r.partition(":")
        try:
            load = float(load)
        except ValueError:
            raise SystemExit(f"--reference {r}: give a load in N, optionally :LABEL (e.g. 7e3:experiment)")
        ax.axhline(load * 1e-3, color="k", ls="--", lw=1, label=label or f"{load * 1e-3:g} kN")
    if args.band:
        try:
            lo, hi = (float(v) for v in args.band.split(","))
        except ValueError:
            raise SystemExit(f"--band {args.band}: give two loads in N, LO,HI (e.g. 5.95e3,8.05e3)")
        ax.axhspan(lo * 1e-3, hi * 1e-3, color="0.85", zorder=0)
    ax.set_xlabel(f"displacement along {args.axis} (mm)")
    ax.set_ylabel("load (kN)")
    if args.title:
        ax.set_title(args.title)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    png = args.out or os.path.join(args.outdir, "load_displacement.png")
    fig.savefig(png, dpi=110)
    with open(os.path.join(args.outdir, "load_displacement.csv"), "w") as f:
        f.write("name,displacement_m,load_N\n")
        for n, dd, ff in rows:
            f.write(f"{n},{dd:e},{ff:e}\n")
    print(f"load_displacement: wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
