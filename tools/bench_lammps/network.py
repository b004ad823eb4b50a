#!/usr/bin/env python3
"""hooke against LAMMPS on exactly the same random spring network, one thread each.

`hooke bench --export-lammps` writes the network hooke's benchmark runs on (nodes, springs,
rest lengths, stiffnesses, initial velocities) as a LAMMPS data file; LAMMPS (Debian's `lmp`)
runs it with `bond_style harmonic` (plain springs) and velocity Verlet. Whole runs alternate
(hooke, LAMMPS, hooke, LAMMPS, ...) because this machine's speed drifts; each hooke run times
plain and dispersive springs in alternating windows itself (`hooke bench --compare`). Reported:
medians of unique spring-updates per second and the ratios.

    python3 tools/bench_lammps/network.py --lattice random3d --nodes 200000 --steps 50 --repeats 3

Needs `lmp` on the PATH (apt-get install lammps) and a release build of hooke.
"""
import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def hooke_compare(hooke, a, env):
    out = subprocess.run(
        [hooke, "bench", "--compare", "--lattice", a.lattice, "--nodes", str(a.nodes),
         "--kernel", "auto", "--threads", "1", "--steps", str(a.steps), "--repeats", "3", "--json"],
        check=True, capture_output=True, text=True, env=env).stdout
    return json.loads(out.strip().splitlines()[-1])


def lammps(lmp, data, dt, a, env):
    out = subprocess.run(
        [lmp, "-in", os.path.join(HERE, "in.network"), "-log", "none", "-var", "data", data, "-var", "dt", repr(dt), "-var", "steps",
         str(a.steps), "-var", "cut", "4.0"],
        check=True, capture_output=True, text=True, env=env).stdout
    m = re.search(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", out)
    if not m:
        sys.exit("could not find LAMMPS's loop time in its output:\n" + out[-2000:])
    bonds = int(re.search(r"(\d+) bonds", out).group(1))
    secs = float(m.group(1))
    return {"seconds_per_step": secs / int(m.group(3)), "bonds": bonds, "atoms": int(m.group(4))}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--lattice", default="random3d", choices=["random3d", "random2d", "hex", "cubic"])
    p.add_argument("--nodes", type=int, default=200000)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--hooke", default=os.path.join(HERE, "..", "..", "target", "release", "hooke"))
    p.add_argument("--lmp", default="lmp")
    p.add_argument("--json", action="store_true")
    a = p.parse_args()
    if shutil.which(a.lmp) is None:
        sys.exit(f"{a.lmp} not found: apt-get install lammps")
    env = dict(os.environ, OMP_NUM_THREADS="1", RAYON_NUM_THREADS="1")
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "network.data")
        first = json.loads(subprocess.run(
            [a.hooke, "bench", "--lattice", a.lattice, "--nodes", str(a.nodes), "--kernel", "auto",
             "--threads", "1", "--law", "plain", "--steps", "1", "--export-lammps", data, "--json"],
            check=True, capture_output=True, text=True, env=env).stdout.strip().splitlines()[-1])
        with open(data) as f:
            dt = float(re.search(r"dt ([0-9.eE+-]+)", f.readline()).group(1))
        plain, disp, lmp = [], [], []
        for r in range(a.repeats):
            h = hooke_compare(a.hooke, a, env)
            plain.append(h["plain_spring_updates_per_s"])
            disp.append(h["dispersive_spring_updates_per_s"])
            l = lammps(a.lmp, data, dt, a, env)
            if l["bonds"] != first["springs"] or l["atoms"] != first["nodes"]:
                sys.exit(f"LAMMPS read {l['atoms']} atoms and {l['bonds']} bonds, hooke has "
                         f"{first['nodes']} nodes and {first['springs']} springs")
            lmp.append(l["bonds"] / l["seconds_per_step"])
            print(f"round {r + 1}: hooke plain {plain[-1] / 1e6:.1f}, dispersive {disp[-1] / 1e6:.1f}, "
                  f"LAMMPS harmonic {lmp[-1] / 1e6:.1f} M spring-updates/s", file=sys.stderr)
    res = {
        "lattice": a.lattice, "nodes": first["nodes"], "springs": first["springs"], "steps": a.steps,
        "repeats": a.repeats, "threads": 1,
        "hooke_plain_spring_updates_per_s": statistics.median(plain),
        "hooke_dispersive_spring_updates_per_s": statistics.median(disp),
        "lammps_harmonic_spring_updates_per_s": statistics.median(lmp),
    }
    res["ratio_hooke_dispersive_over_lammps"] = res["hooke_dispersive_spring_updates_per_s"] / res["lammps_harmonic_spring_updates_per_s"]
    res["ratio_hooke_plain_over_lammps"] = res["hooke_plain_spring_updates_per_s"] / res["lammps_harmonic_spring_updates_per_s"]
    if a.json:
        print(json.dumps(res))
    else:
        print(f"{res['lattice']}, {res['nodes']} nodes, {res['springs']} springs, 1 thread, medians of "
              f"{a.repeats} alternating rounds (M spring-updates/s):")
        print(f"  hooke dispersive {res['hooke_dispersive_spring_updates_per_s'] / 1e6:.1f}, hooke plain "
              f"{res['hooke_plain_spring_updates_per_s'] / 1e6:.1f}, LAMMPS bond_style harmonic "
              f"{res['lammps_harmonic_spring_updates_per_s'] / 1e6:.1f}")
        print(f"  hooke dispersive / LAMMPS plain: {res['ratio_hooke_dispersive_over_lammps']:.2f}")


if __name__ == "__main__":
    main()
