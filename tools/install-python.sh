#!/usr/bin/env bash
# The optional Python package (python/): builds the extension with maturin (fetched by pip as
# the build backend) and installs it with its test dependencies. Run from anywhere.
set -euo pipefail
cd "$(dirname "$0")/.."
# Reuse the workspace's compiled crates: maturin builds python/ as a member of the workspace.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$PWD/target}"
python3 -m pip install -q --disable-pip-version-check "./python[test]"
python3 -c "import hooke; print('hooke', hooke.__version__, 'from', hooke.__file__)"
