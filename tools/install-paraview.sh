#!/usr/bin/env bash
# Installs ParaView's Python (pvpython) from Debian, for tools/check_paraview.py.
set -euo pipefail
if command -v pvpython >/dev/null; then
  echo "pvpython is already installed"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq python3-paraview
