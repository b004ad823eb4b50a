#!/usr/bin/env bash
# Side-by-side throughput: hooke against LAMMPS PERI (peri/pmb, peri/lps) on the same block,
# same machine, same run, one thread each. Prints unique spring (bond) updates per second.
#
#   tools/bench_lammps/run.sh [points_per_side] [steps]      (default 100 -> 10^6 points, 20 steps)
#
# Needs LAMMPS with the PERI package: `apt-get install lammps` (Debian's `lmp`).
set -euo pipefail
n=${1:-100}
steps=${2:-20}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
command -v lmp >/dev/null || { echo "lmp not found: apt-get install lammps" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# LAMMPS: n^3 points (the input's region spans n-1 lattice spacings, n planes, per side).
lammps() {
  local style=$1
  (cd "$work" && OMP_NUM_THREADS=1 lmp -in "$here/in.block" -var style "$style" -var n "$n" -var steps "$steps" -log "log.$style" -screen none)
  python3 - "$work/log.$style" "$steps" <<'PY'
import re, sys
log = open(sys.argv[1]).read()
steps = int(sys.argv[2])
m = re.search(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", log)
secs, atoms = float(m.group(1)), int(m.group(4))
# Bonds: LAMMPS stores each bond in both partners' families; the number of unique bonds of a
# box of n^3 points with 18 neighbours is counted exactly below.
n = round(atoms ** (1 / 3))
m1 = n - 1
bonds = 3 * m1 * n * n + 6 * m1 * m1 * n
print(f"{atoms} {bonds} {secs} {bonds * steps / secs}")
PY
}

hooke() {
  local law=$1
  "$root/target/release/hooke" --threads 1 bench --nodes $((n * n * n)) --steps "$steps" --law "$law" --json |
    python3 -c 'import json,sys; d=json.load(sys.stdin); print(d["nodes"], d["springs"], d["seconds"], d["spring_updates_per_s"], d["kernel"])'
}

(cd "$root" && cargo build --release -q -p hooke-cli)
read -r a1 b1 s1 r1 < <(lammps pmb)
read -r a2 b2 s2 r2 < <(lammps lps)
read -r a3 b3 s3 r3 k3 < <(hooke plain)
read -r a4 b4 s4 r4 k4 < <(hooke dispersive)
printf '\n%s points, %s steps, 1 thread, %s\n\n' "$a4" "$steps" "$(lscpu | sed -n 's/^Model name: *//p')"
printf '| code | model | Poisson ratio | bonds | unique bond updates / s | vs LAMMPS peri/pmb |\n|---|---|---|---|---|---|\n'
awk -v r="$r1" -v b="$b1" 'BEGIN { printf "| LAMMPS | peri/pmb | 1/4 only | %d | %.1f M | 1.0x |\n", b, r/1e6 }'
awk -v r="$r2" -v b="$b2" -v ref="$r1" 'BEGIN { printf "| LAMMPS | peri/lps | any | %d | %.1f M | %.2fx |\n", b, r/1e6, r/ref }'
awk -v r="$r3" -v b="$b3" -v ref="$r1" -v k="$k3" 'BEGIN { printf "| hooke (%s) | plain springs | 1/4 only | %d | %.1f M | %.1fx |\n", k, b, r/1e6, r/ref }'
awk -v r="$r4" -v b="$b4" -v ref="$r1" -v k="$k4" 'BEGIN { printf "| hooke (%s) | dispersive | any | %d | %.1f M | %.1fx |\n", k, b, r/1e6, r/ref }'
