"""The paper's Fig. 8: a 2 x 3 x 2 block of the cubic lattice compressed along y to 75 % of its
length, at Poisson's ratios -0.99 (close to the admissible end, -1), 0, 0.25 and 0.47, rendered
side by side with pyvista (off-screen) into fig8_compression.png.

The bottom face is held along y only and the top face is pushed down by a quarter of the
block's height with a smooth ramp, slowly and with damping, so that the block passes through
near-equilibrium states (lattice units: E = 1 Pa, rho = 1 kg/m^3, 1 m spacing units). What the
paper shows, and the printout checks: the auxetic block (nu -> -1) draws its sides in, the nu = 0
block keeps its width, and the nearly incompressible one (0.47) bulges.

    python3 python/examples/fig8_compression.py [OUT_DIR]
"""
import os
import sys
from pathlib import Path

import numpy as np

import hooke

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("fig8.out")
small = os.environ.get("HOOKE_EXAMPLE_SMALL")
spacing = 0.25 if small else 0.1
ramp = 40.0  # s: about 13 times the time a wave takes to cross the block

CASE = f"""
[lattice]
kind = "cubic"
spacing = {spacing}

[material]
youngs = 1.0
poisson = 0.25
density = 1.0

[geometry]
box = {{ min = [0.0, 0.0, 0.0], max = [2.0, 3.0, 2.0] }}

[[boundary]]
region = {{ face = "y-" }}
fixed = ["y"]

[[boundary]]
region = {{ face = "y+" }}
displacement = [{{ axis = "y", value = -0.75, ramp = {ramp}, smooth = true }}]

[solver]
end_time = {ramp * 1.5}
damping = 0.5

[output]
every = {ramp * 1.5 / 3}
"""

results = []
for nu in [-0.99, 0.0, 0.25, 0.47]:
    sim = hooke.load_case(CASE, set={"material.poisson": nu}, out=out / f"nu{nu}", name="fig8")
    sim.run()
    x = sim.positions + sim.displacement
    mid = np.abs(sim.positions[:, 1] - 1.5) < 0.5 * spacing
    width = x[mid, 0].max() - x[mid, 0].min()
    height = x[:, 1].max() - x[:, 1].min()
    results.append((nu, x, width))
    print(f"nu = {nu:+.2f}: height {height:.3f} (of 3), mid-height width {width:.3f} (of 2), "
          f"lateral strain {width / 2 - 1:+.3f}")
    sim.finish()

widths = [w for _, _, w in results]
# Auxetic draws in, zero keeps its width (to a few %: the ends are free to slide), 0.47 bulges;
# at nu -> -1 the lateral strain is -nu times the axial one (-0.25), within 10 %.
assert abs((widths[0] / 2 - 1) - 0.99 * -0.25) < 0.1 * 0.25
assert widths[0] < 2.0 - 0.05 and abs(widths[1] - 2.0) < 0.08 and widths[3] > widths[2] > 2.0

import pyvista as pv

pv.OFF_SCREEN = True
plot = pv.Plotter(shape=(1, 4), off_screen=True, window_size=(1600, 520))
for k, (nu, x, _) in enumerate(results):
    plot.subplot(0, k)
    cloud = pv.PolyData(x)
    cloud["lateral displacement"] = x[:, 0] - 1.0
    plot.add_mesh(cloud, scalars="lateral displacement", render_points_as_spheres=True,
                  point_size=6 if small else 4, cmap="coolwarm", clim=[-1.3, 1.3],
                  show_scalar_bar=False)
    plot.add_text(f"nu = {nu:g}", font_size=12)
    plot.add_mesh(pv.Box(bounds=(0, 2, 0, 3, 0, 2)).outline(), color="grey")
    plot.camera_position = [(1.0, 1.5, 12.0), (1.0, 1.5, 1.0), (0.0, 1.0, 0.0)]
    plot.enable_parallel_projection()
    plot.camera.parallel_scale = 1.9
plot.screenshot(str(out / "fig8_compression.png"))
print(f"picture: {out / 'fig8_compression.png'}")
