#!/usr/bin/env bash
# HDF5 frames under MPI (CI; needs tools/install-hdf5.sh and tools/install-mpi.sh first): a build
# with both features writes, under `mpirun -np 2` and `-np 3`, an HDF5 file (rank 0 writes the
# frames whole) whose every dataset is bit for bit the one-process run's, and the same XDMF.
# Usage: tools/mpi_hdf5_check.sh SCRATCH_DIR
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:?usage: tools/mpi_hdf5_check.sh SCRATCH_DIR}
rm -rf "$work" && mkdir -p "$work"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mpirun="mpirun --oversubscribe --bind-to none"

cargo build --release -q --workspace --bins --features hooke-cli/mpi,hooke-cli/hdf5
cp target/release/hooke "$work/hooke"
args=(run cases/kalthoff_winkler.toml --scale 0.3 --set solver.end_time=10e-6
  --set 'output.format=["vtk", "hdf5"]')
"$work/hooke" "${args[@]}" --out "$work/alone" > /dev/null
for np in 2 3; do
  $mpirun -np "$np" "$work/hooke" "${args[@]}" --out "$work/np$np" > /dev/null
  python3 tools/compare_h5.py "$work/alone/kalthoff_winkler.h5" "$work/np$np/kalthoff_winkler.h5"
  cmp "$work/alone/kalthoff_winkler.xdmf" "$work/np$np/kalthoff_winkler.xdmf"
  python3 tools/compare_runs.py "$work/alone" "$work/np$np" | tail -1
  echo "kalthoff_winkler, HDF5 and VTK: -np $np bit-identical to one process"
done
