#!/usr/bin/env python3
"""Plot the energy history of a hooke run (CASE_energy.csv) to PNG.

    python3 tools/energy_plot.py OUTDIR

Kinetic and strain energy, the work put in (external, supports, body force), the energy released
by broken springs, the damping losses, and the balance error. Writes OUTDIR/energy.png.
"""
import glob
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(outdir):
    found = glob.glob(os.path.join(outdir, "*_energy.csv"))
    if not found:
        raise SystemExit(f"{outdir}: no *_energy.csv (is this the output folder of `hooke run`?)")
    d = np.genfromtxt(found[0], delimiter=",", names=True)
    t = d["time"] * 1e6
    fig, ax = plt.subplots(figsize=(9, 5.5))
    ax.plot(t, d["kinetic"], label="kinetic")
    ax.plot(t, d["strain_direct"] + d["strain_dispersive"], label="strain (direct + dispersive)")
    ax.plot(t, d["external_work"] + d["boundary_work"] + d["body_work"], label="work put in")
    ax.plot(t, d["released"], label="released by broken springs")
    ax.plot(t, d["dissipated"], label="damping losses")
    ax.plot(t, d["balance_error"], "k:", label="balance error")
    ax.set_xlabel("time (us)")
    ax.set_ylabel("energy (J)")
    ax.legend()
    ax.grid(alpha=0.3)
    out = os.path.join(outdir, "energy.png")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"energy_plot: wrote {out}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
