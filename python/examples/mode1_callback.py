"""The mode-I plate run from Python, with a callback that records the crack tip.

A pre-cracked glass plate (cases/mode1_plate.toml) is pulled apart; every microsecond the
callback finds the crack tip as the rightmost node of the crack band (damage above 0.3, away
from the gripped edges) and records it. The tip's speed comes out below the Rayleigh speed of
glass (about 3.3 km/s), as it must.

    python3 python/examples/mode1_callback.py [OUT_DIR]
"""
import os
import sys
from pathlib import Path

import numpy as np

import hooke

root = Path(__file__).resolve().parents[2]
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("mode1_callback.out")
small = os.environ.get("HOOKE_EXAMPLE_SMALL")
sim = hooke.load_case(root / "cases" / "mode1_plate.toml", scale=0.25 if small else 0.5,
                      set={"solver.end_time": 30e-6 if small else 60e-6}, out=out / "run")

tips = []


def record(s):
    x = s.positions
    cracked = (s.damage > 0.3) & (x[:, 1] > 2e-3) & (x[:, 1] < 28e-3)
    tip = x[cracked, 0].max() if cracked.any() else 15e-3
    tips.append((s.time, tip))
    print(f"t = {s.time * 1e6:5.1f} us  tip at x = {tip * 1e3:6.2f} mm  broken springs {s.broken()[0]}")


sim.run(every=1e-6, callback=record)
summary = sim.finish()
t, x = np.array(tips).T
moving = x > x[0] + 1e-3
if moving.sum() >= 3:
    speed = np.polyfit(t[moving], x[moving], 1)[0]
    print(f"mean crack speed {speed:.0f} m/s (Rayleigh speed of glass about 3300 m/s)")
    assert 0 < speed < 3300
np.savetxt(out / "crack_tip.csv", np.c_[t, x], delimiter=",", header="time_s,tip_x_m", comments="")
print(f"{summary['broken_springs']} springs broken; frames in {summary['output_dir']}")
