#!/usr/bin/env bash
# Installs Open MPI and libclang (rsmpi's bindgen) for hooke's optional `mpi` feature
# (Debian/Ubuntu). Then: cargo build --release -p hooke-cli --features mpi
set -euo pipefail
if [ -e /usr/lib/x86_64-linux-gnu/openmpi/include/mpi.h ] || [ -e /usr/include/mpi.h ] ||
   { command -v mpicc >/dev/null && mpicc --showme:incdirs >/dev/null 2>&1 && \
     ls "$(mpicc --showme:incdirs | cut -d' ' -f1)/mpi.h" >/dev/null 2>&1; }; then
  if ls /usr/lib/llvm-*/lib/libclang*.so* >/dev/null 2>&1 || ls /usr/lib/x86_64-linux-gnu/libclang*.so* >/dev/null 2>&1; then
    echo "Open MPI and libclang are already installed"
    exit 0
  fi
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libopenmpi-dev openmpi-bin libclang-dev pkg-config
