"""A parameter sweep from Python: the peak load of the mode-I plate against Poisson's ratio.

Each run is the same pre-cracked plate with another nu (a `set` override, as `--set` on the
command line); the peak of the top grip's reaction is read from the run as it goes. The plot
goes to poisson_sweep.png.

    python3 python/examples/poisson_sweep.py [OUT_DIR]
"""
import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import hooke

root = Path(__file__).resolve().parents[2]
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("poisson_sweep.out")
small = os.environ.get("HOOKE_EXAMPLE_SMALL")
nus = [0.0, 0.22] if small else [-0.3, 0.0, 0.22, 0.4]
peaks = []
for nu in nus:
    sim = hooke.load_case(root / "cases" / "mode1_plate.toml", scale=0.25 if small else 0.5,
                          set={"material.poisson": nu, "solver.end_time": 20e-6 if small else 40e-6},
                          out=out / f"nu{nu}")
    peak = 0.0

    def watch(s):
        global peak
        peak = max(peak, abs(s.reactions()["boundary[0]"].force[1]))

    sim.run(every=0.5e-6, callback=watch)
    sim.finish()
    peaks.append(peak)
    print(f"nu = {nu:5.2f}: peak grip force {peak:.1f} N, {sim.broken()[0]} springs broken")

plt.plot(nus, peaks, "o-")
plt.xlabel("Poisson's ratio")
plt.ylabel("peak grip force (N)")
plt.title("mode-I plate: peak load against Poisson's ratio")
plt.savefig(out / "poisson_sweep.png", dpi=120)
print(f"plot in {out / 'poisson_sweep.png'}")
