#!/usr/bin/env bash
# The MPI build's promises, checked on shipped cases (CI; needs tools/install-mpi.sh first):
#   - `mpirun -np N hooke run` for N = 1..4 (oversubscribed on small machines) writes frames
#     (in pieces, one per rank, with a .pvtu: meshio reads the pieces, pyvista the .pvtu),
#     histories and a checkpoint identical bit for bit to the build without MPI, with breaking,
#     rigid-body contact and fragment contact;
#   - a run checkpointed with one N resumes with another and still gives those bits;
#   - `run --pieces` (each rank holding only its piece of a random body) gives those bits too,
#     with breaking, rigid-body and fragment contact, a checkpoint per rank that resumes; a
#     regular lattice's box is refused on pieces with the reason;
#   - `bench --parts` (each rank setting up only its part of a random block) steps with the bits
#     of one process;
#   - `run --parts` (each rank building only its part of a jittered random body, none the whole)
#     gives those bits too, fresh and resumed; a body it cannot build is refused with the reason;
#   - `bench --pieces` (each rank holding only its piece of a random block) steps with the bits
#     of the build without MPI, and a rank's arrays shrink with N;
#   - bad input stops every rank with one message and exit code 2.
# Usage: tools/mpi_check.sh SCRATCH_DIR [--full]
# CI runs the quick set (about 7 minutes here): every promise above on at least one case and
# split. `--full` adds the larger cases and every process count (about 14 minutes on a 2-core
# machine); run it before changing the team code.
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:?usage: tools/mpi_check.sh SCRATCH_DIR [--full]}
full=0
[ "${2:-}" = "--full" ] && full=1
# `sizes QUICK FULL`: the process counts of a check in this mode.
sizes() { if [ "$full" = 1 ]; then echo "$2"; else echo "$1"; fi; }
rm -rf "$work" && mkdir -p "$work"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mpirun="mpirun --oversubscribe --bind-to none"

# Built for the whole workspace, as the test command builds it (a build of one package resolves
# the dependencies' features otherwise, and rebuilds most of the tree).
cargo build --release -q --workspace --bins
cp target/release/hooke "$work/hooke"
cargo build --release -q --workspace --bins --features hooke-cli/mpi
cp target/release/hooke "$work/hooke-mpi"

extra=() # further arguments of both runs
check() { # name case scale end_time sizes...
  local name=$1 case=$2 scale=$3 end=$4
  shift 4
  "$work/hooke" run "$case" --scale "$scale" --set solver.end_time="$end" "${extra[@]}" \
    --out "$work/$name.alone" > /dev/null
  for np in "$@"; do
    $mpirun -np "$np" "$work/hooke-mpi" run "$case" --scale "$scale" --set solver.end_time="$end" \
      "${extra[@]}" --out "$work/$name.np$np" > "$work/$name.np$np.log"
    python3 tools/compare_runs.py "$work/$name.alone" "$work/$name.np$np" | tail -1
    cmp "$work/$name.alone/"*.ckpt "$work/$name.np$np/"*.ckpt
    if [ "$np" -gt 1 ]; then
      python3 tools/check_pieces.py "$work/$name.alone" "$work/$name.np$np" | tail -1
    fi
    echo "$name: -np $np bit-identical to the build without MPI (frames read by meshio piece by piece and by pyvista whole, histories, checkpoint)"
  done
}
check kalthoff_winkler cases/kalthoff_winkler.toml 0.3 20e-6 $(sizes "1 3" "1 2 3 4")
check sphere_impact cases/sphere_impact_glass.toml 0.8 8e-6 $(sizes "3" "2 3")
check compression_block cases/compression_block.toml 1.0 10e-6 3
# Without contact the ranks trade only their halos between outputs: the mode-I plate (pre-crack,
# prescribed velocities, breaking; at 4 ranks two of them own no nodes and write no piece) and
# the random glass plate (random lattice, branching cracks).
check mode1_plate cases/mode1_plate.toml 1.0 60e-6 $(sizes "4" "3 4")
if [ "$full" = 1 ]; then
  check glass_branching_random cases/glass_branching_random.toml 0.6 46e-6 2 3
fi
# Every split runs: bodies so small or so sized that some ranks own no node (after the body's
# short last chunk too), or fewer than 64 (one window of the vector paths). mode1_plate at
# --scale 0.25 has 425 nodes (one chunk: at -np 3 and 4 ranks own nothing before and after it;
# this once panicked and hung), at 0.5 its last chunk is short; the random glass plate at 0.27
# has 4157 nodes (a rank owns the last 61) and at 0.38 8231 (the last 39).
check mode1_small cases/mode1_plate.toml 0.25 60e-6 2 3 4 5
check mode1_half cases/mode1_plate.toml 0.5 30e-6 3
check glass_random_small cases/glass_branching_random.toml 0.25 20e-6 3
check glass_random_61 cases/glass_branching_random.toml 0.27 20e-6 2 3
check glass_random_39 cases/glass_branching_random.toml 0.38 20e-6 $(sizes "3" "3 4")
# The spring-energy criterion has no stretch screen: each rank decides its own springs after
# the step, and the ranks trade what they found.
extra=(--set 'material.criterion="energy"')
check glass_branching_energy cases/glass_branching.toml 0.5 30e-6 $(sizes "3" "2 3")
extra=()

# Checkpointed with 2 ranks, resumed with 3.
$mpirun -np 2 "$work/hooke-mpi" run cases/kalthoff_winkler.toml --scale 0.3 --set solver.end_time=10e-6 \
  --out "$work/resumed" > /dev/null
$mpirun -np 3 "$work/hooke-mpi" run cases/kalthoff_winkler.toml --scale 0.3 --set solver.end_time=20e-6 \
  --out "$work/resumed" --resume "$work/resumed/kalthoff_winkler.ckpt" > /dev/null
python3 tools/compare_runs.py "$work/kalthoff_winkler.alone" "$work/resumed" | tail -1
cmp "$work/kalthoff_winkler.alone/kalthoff_winkler.ckpt" "$work/resumed/kalthoff_winkler.ckpt"
echo "kalthoff_winkler: checkpointed with -np 2, resumed with -np 3: bit-identical"

# Distributed memory: with `run --pieces` each rank keeps only its piece of the body after the
# set-up (random lattices, breaking, contact). Frames, histories and the final state
# must be the bits of the build without MPI, each rank writes its own checkpoint, and a run on
# pieces resumes from them (on the same N), or from a whole checkpoint.
hold=--pieces # how the ranks hold the body: --pieces (cut after a whole set-up) or --parts
check_pieces() { # name case scale end_time sizes... (the run alone is `check`'s, or made here)
  local name=$1 case=$2 scale=$3 end=$4
  shift 4
  if [ ! -d "$work/$name.alone" ]; then
    "$work/hooke" run "$case" --scale "$scale" --set solver.end_time="$end" "${extra[@]}" \
      --out "$work/$name.alone" > /dev/null
  fi
  for np in "$@"; do
    local out="$work/$name.${hold#--}$np"
    $mpirun -np "$np" "$work/hooke-mpi" run "$case" --scale "$scale" --set solver.end_time="$end" \
      "${extra[@]}" $hold --out "$out" > "$out.log"
    python3 tools/compare_runs.py "$work/$name.alone" "$out" | tail -1
    python3 tools/check_pieces.py "$work/$name.alone" "$out" | tail -1
    for ((r = 0; r < np; r++)); do
      local ckpt="$out/$(basename "$case" .toml).${r}of$np.ckpt"
      test -s "$ckpt" || { echo "$name $hold -np $np: no checkpoint of rank $r ($ckpt)"; exit 1; }
    done
    echo "$name: -np $np $hold bit-identical to the build without MPI (frames, histories), a checkpoint per rank"
  done
}
check_pieces mode1_plate cases/mode1_plate.toml 1.0 60e-6 $(sizes "4" "2 4")
# A body of several materials on pieces (each holds some of the materials only), and shared.
check phases_plate crates/case/tests/data/phases_plate.toml 2.0 20e-6 2 3
check_pieces phases_plate crates/case/tests/data/phases_plate.toml 2.0 20e-6 3
# Random inclusions (every rank places the same), an interface, Weibull strength.
check inclusions_plate crates/case/tests/data/inclusions_plate.toml 1.0 20e-6 3
check_pieces mode1_small cases/mode1_plate.toml 0.25 60e-6 2 4
check_pieces glass_random_61 cases/glass_branching_random.toml 0.27 20e-6 2 3
# Checkpointed on 3 ranks' pieces, resumed on them (the random glass plate; small in the quick
# set).
if [ "$full" = 1 ]; then
  resume=(glass_branching_random 0.6 20e-6 46e-6)
else
  resume=(glass_random_61 0.27 10e-6 20e-6)
fi
if [ "$full" = 1 ]; then # (the quick set's ran above)
  check_pieces "${resume[0]}" cases/glass_branching_random.toml "${resume[1]}" "${resume[3]}" 3
fi
$mpirun -np 3 "$work/hooke-mpi" run cases/glass_branching_random.toml --scale "${resume[1]}" \
  --set solver.end_time="${resume[2]}" --pieces --out "$work/resumed_pieces" > /dev/null
$mpirun -np 3 "$work/hooke-mpi" run cases/glass_branching_random.toml --scale "${resume[1]}" \
  --set solver.end_time="${resume[3]}" --pieces --out "$work/resumed_pieces" \
  --resume "$work/resumed_pieces/glass_branching_random.ckpt" > /dev/null
python3 tools/compare_runs.py "$work/${resume[0]}.alone" "$work/resumed_pieces" | tail -1
for r in 0 1 2; do
  cmp "$work/${resume[0]}.pieces3/glass_branching_random.${r}of3.ckpt" \
    "$work/resumed_pieces/glass_branching_random.${r}of3.ckpt"
done
echo "${resume[0]}: checkpointed on 3 ranks' pieces and resumed: bit-identical"
# Kalthoff-Winkler on pieces, long enough for fragment contact across the cracks (pairs whose
# nodes are on different ranks), and the L-panel (3D, an STL body, a rigid load).
check_pieces kalthoff_winkler_60us cases/kalthoff_winkler.toml 0.3 60e-6 $(sizes "3" "2 3 4")
if [ "$full" = 1 ]; then
  check_pieces l_panel cases/l_panel.toml 0.5 12e-3 2 3
fi
# `refused NAME WHAT ARGS...`: `mpirun -np 2 hooke run ARGS` must stop with exit 2 and one message.
refused() {
  local name=$1 what=$2
  shift 2
  set +e
  $mpirun -np 2 "$work/hooke-mpi" run "$@" --out "$work/$name" > /dev/null 2> "$work/$name.err"
  local rc=$?
  set -e
  if [ "$rc" -ne 2 ] || [ "$(grep -c '^error:' "$work/$name.err")" -ne 1 ]; then
    echo "$what not refused (exit $rc)"; cat "$work/$name.err"; exit 1
  fi
  echo "$what: refused (exit $rc): $(grep '^error:' "$work/$name.err")"
}
# A regular lattice's box is refused on pieces with the reason.
refused hex_pieces "a hexagonal box with --pieces" cases/glass_branching.toml --scale 0.3 --pieces

# A set-up from parts: no rank builds the whole body (random lattices on a jittered grid). The
# mode-I plate (pre-crack, grips moved, no-fail layers) and the notched 3D bar (a traction, a
# face held, a polygonal pre-crack; at 4 ranks one owns no node), then checkpointed on 3 ranks'
# parts and resumed on them.
hold=--parts
extra=(--set 'lattice.sampler="jitter"')
check_pieces mode1_jitter cases/mode1_plate.toml 1.0 60e-6 $(sizes "2" "2 3")
# An anisotropic plate: every rank calibrates (or reads the cache) alike.
check_pieces fibre_jitter cases/fibre_notch_plate.toml 1.0 90e-6 2
# A rigid projectile placed by its start gap, fragment contact across the cracks; in 2D and 3D.
check_pieces kw_jitter cases/kalthoff_winkler.toml 0.3 60e-6 $(sizes "2" "2 4")
check_pieces kw3d_jitter cases/kalthoff_winkler_3d.toml 0.3 10e-6 $(sizes "2" "2 3")
# A body of several materials: a rank's part holds some of them only, and the step (its
# damage-proof bound over every material's q) is still the whole body's.
check_pieces phases_jitter crates/case/tests/data/phases_plate.toml 2.0 20e-6 2 3
extra=() # (its nodes are jittered already)
check_pieces inclusions_plate crates/case/tests/data/inclusions_plate.toml 1.0 20e-6 2 3
check_pieces notched_bar_3d cases/notched_bar_3d.toml 1.0 20e-6 $(sizes "3" "2 3 4")
$mpirun -np 3 "$work/hooke-mpi" run cases/notched_bar_3d.toml --set solver.end_time=10e-6 \
  --parts --out "$work/resumed_parts" > /dev/null
$mpirun -np 3 "$work/hooke-mpi" run cases/notched_bar_3d.toml --set solver.end_time=20e-6 \
  --parts --out "$work/resumed_parts" --resume "$work/resumed_parts/notched_bar_3d.ckpt" > /dev/null
python3 tools/compare_runs.py "$work/notched_bar_3d.alone" "$work/resumed_parts" | tail -1
for r in 0 1 2; do
  cmp "$work/notched_bar_3d.parts3/notched_bar_3d.${r}of3.ckpt" "$work/resumed_parts/notched_bar_3d.${r}of3.ckpt"
done
echo "notched_bar_3d: checkpointed on 3 ranks' parts and resumed: bit-identical"
hold=--pieces
# What a set-up from parts cannot build is refused with the reason: the default Poisson-disk
# sampling places each node against those before it.
refused poisson_parts "a Poisson-disk body with --parts" cases/mode1_plate.toml --scale 0.3 --parts

# Distributed memory, first part: with `bench --pieces` each rank keeps only its piece of the
# block (its own nodes and ghosts) and drops the whole body and state after the set-up. The steps
# must give the bits of the build without MPI (`state_digest`: every node's displacement and
# velocity), and rank 0's arrays must shrink with N: at most 1/N of one process's plus a quarter
# (the ghosts and the dummies that align a piece on a chunk).
digest() { python3 -c 'import json,sys; d=json.load(sys.stdin); print(d["state_digest"], round(d["memory_bytes_per_node"]))'; }
for lat in random3d random2d; do
  read -r want alone < <("$work/hooke" bench --lattice $lat --nodes 60000 --steps 20 --threads 1 --json | digest)
  for np in $(sizes "3" "2 3 4"); do
    read -r got bytes < <($mpirun -np $np "$work/hooke-mpi" bench --lattice $lat --nodes 60000 --steps 20 \
      --threads 1 --pieces --json | digest)
    if [ "$got" != "$want" ]; then
      echo "bench --pieces $lat -np $np: state digest $got, the build without MPI $want"; exit 1
    fi
    python3 -c "import sys; b, a, n = $bytes, $alone, $np; sys.exit(0 if b <= a * (1 / n + 0.25) else 1)" || {
      echo "bench --pieces $lat -np $np: rank 0 holds $bytes bytes per node, one process $alone"; exit 1; }
    echo "bench --pieces $lat -np $np: bit-identical (digest $got), rank 0 holds $bytes bytes per node of the block (one process $alone)"
  done
done

# Distributed set-up: with `bench --parts` each rank samples, triangulates and numbers only its
# part of a jittered random block and its surroundings; no rank ever holds the whole block. The
# steps must give the bits of the build without MPI set up the same way (one part), and rank 0's
# piece must hold fewer nodes than the block.
parts() { python3 -c 'import json,sys; d=json.load(sys.stdin); print(d["state_digest"], d["nodes"], d["piece_nodes"])'; }
for lat in random3d random2d; do
  read -r want nodes _ < <("$work/hooke" bench --lattice $lat --parts --nodes 60000 --steps 20 --threads 1 --json | parts)
  for np in $(sizes "3" "2 3 4"); do
    read -r got n held < <($mpirun -np $np "$work/hooke-mpi" bench --lattice $lat --parts --nodes 60000 \
      --steps 20 --threads 1 --json | parts)
    if [ "$got" != "$want" ] || [ "$n" != "$nodes" ] || [ "$held" -ge "$nodes" ]; then
      echo "bench --parts $lat -np $np: digest $got of $n nodes (rank 0 holds $held), alone $want of $nodes"; exit 1
    fi
    echo "bench --parts $lat -np $np: bit-identical (digest $got), rank 0 set up and holds $held of the $n nodes"
  done
done

# Bad input: every rank stops, one message, exit code 2.
printf '[lattice]\nkind = "hex"\nspacing = -1e-3\n' > "$work/bad.toml"
set +e
$mpirun -np 3 "$work/hooke-mpi" run "$work/bad.toml" --out "$work/bad" > "$work/bad.out" 2> "$work/bad.err"
rc=$?
set -e
n=$(grep -c '^error:' "$work/bad.err" || true)
if [ "$rc" -eq 0 ] || [ "$n" -ne 1 ]; then
  echo "bad input under mpirun: exit $rc, $n error lines (want non-zero and 1)"; cat "$work/bad.err"; exit 1
fi
echo "bad input under mpirun -np 3: exit $rc, one message: $(grep '^error:' "$work/bad.err")"
# Quasi-static runs are refused with the reason.
set +e
$mpirun -np 2 "$work/hooke-mpi" run crates/case/tests/data/quasi_static.toml --out "$work/qs" > /dev/null 2> "$work/qs.err"
rc=$?
set -e
grep -q "one process" "$work/qs.err" || { echo "quasi-static under mpirun not refused (exit $rc)"; cat "$work/qs.err"; exit 1; }
echo "quasi-static under mpirun: refused (exit $rc): $(grep '^error:' "$work/qs.err")"

# A failure anywhere ends the whole job within seconds, with that rank's message and a non-zero
# exit (issue "A failed rank never hangs a job"). HOOKE_TEST_FAIL=KIND:RANK:STEP, read by the
# binary for these tests alone, injects a panic in the driver or in a worker thread, an exit
# without MPI_Finalize, or an error in one rank's set-up; `kill -9` kills a rank from outside.
# What was written before the failure stays: the run resumes from its last checkpoint and ends
# with the bits of the build without MPI.
fails() { # name KIND:RANK:STEP np args...
  local name=$1 fault=$2 np=$3
  shift 3
  local rank
  rank=$(echo "$fault" | cut -d: -f2)
  local t0=$SECONDS
  set +e
  HOOKE_TEST_FAIL=$fault timeout 120 $mpirun -np "$np" "$work/hooke-mpi" run "$@" --out "$work/$name" \
    > "$work/$name.log" 2>&1
  local rc=$?
  set -e
  local took=$((SECONDS - t0))
  if [ "$rc" -eq 0 ] || [ "$rc" -eq 124 ] || [ "$took" -gt 30 ]; then
    echo "$name ($fault on $np ranks): exit $rc after $took s (want non-zero within 30 s)"; cat "$work/$name.log"; exit 1
  fi
  grep -Eq "rank $rank of $np|Process name: \[\[[0-9]+,[0-9]+\],$rank\]" "$work/$name.log" || {
    echo "$name: the message does not name rank $rank"; cat "$work/$name.log"; exit 1; }
  echo "$name: $fault on $np ranks ended the job in $took s with exit $rc, naming rank $rank"
}
fails fail_panic panic:1:500 3 cases/mode1_plate.toml
fails fail_worker worker-panic:2:500 3 cases/mode1_plate.toml --pieces
fails fail_exit exit:1:500 3 cases/mode1_plate.toml
fails fail_error error:2:0 3 cases/mode1_plate.toml
fails fail_error_parts error:1:0 2 cases/notched_bar_3d.toml --parts
# Resumed from the checkpoint the failed job wrote (at 10 and 20 us, before step 500), on the
# same or another number of ranks: the frames and histories of the uninterrupted run, bit for bit.
ls "$work/fail_panic/"*.ckpt > /dev/null
$mpirun -np 3 "$work/hooke-mpi" run cases/mode1_plate.toml --out "$work/fail_panic" \
  --resume "$work/fail_panic/mode1_plate.ckpt" > /dev/null
python3 tools/compare_runs.py "$work/mode1_plate.alone" "$work/fail_panic" | tail -1
cmp "$work/mode1_plate.alone/mode1_plate.ckpt" "$work/fail_panic/mode1_plate.ckpt"
echo "fail_panic: resumed after the failure, bit-identical to the uninterrupted run"
# kill -9 of one rank, once the run has written its first checkpoint.
rm -rf "$work/fail_kill"
t0=$SECONDS
$mpirun -np 3 "$work/hooke-mpi" run cases/mode1_plate.toml --scale 2 --out "$work/fail_kill" \
  > "$work/fail_kill.log" 2>&1 &
job=$!
for _ in $(seq 600); do
  [ -e "$work/fail_kill/mode1_plate.ckpt" ] && break
  sleep 0.1
done
test -e "$work/fail_kill/mode1_plate.ckpt" || { echo "fail_kill: no checkpoint written"; cat "$work/fail_kill.log"; exit 1; }
victim=$(pgrep -x hooke-mpi | tail -1)
killed=$SECONDS
kill -9 "$victim"
set +e
timeout 60 tail --pid="$job" -f /dev/null
wait "$job"
rc=$?
set -e
took=$((SECONDS - killed))
if [ "$rc" -eq 0 ] || [ "$took" -gt 30 ]; then
  echo "fail_kill: kill -9 of a rank: exit $rc after $took s"; cat "$work/fail_kill.log"; exit 1
fi
$mpirun -np 2 "$work/hooke-mpi" run cases/mode1_plate.toml --scale 2 --out "$work/fail_kill" \
  --resume "$work/fail_kill/mode1_plate.ckpt" --set solver.end_time=25e-6 > /dev/null
echo "fail_kill: kill -9 of one rank ended the job in $took s (exit $rc, $((killed - t0)) s into the run); its checkpoint resumed on 2 ranks"
