#!/usr/bin/env bash
# Installs the system HDF5 library that hooke's optional `hdf5` feature builds against
# (Debian/Ubuntu). Then: cargo build --release -p hooke-cli --features hdf5
set -euo pipefail
if pkg-config --exists hdf5 2>/dev/null || [ -e /usr/include/hdf5/serial/hdf5.h ]; then
  echo "libhdf5-dev is already installed"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libhdf5-dev pkg-config
