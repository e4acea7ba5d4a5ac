#!/usr/bin/env bash
# Makes bench/.venv, a Python virtual environment with VTK (PyPI wheels) and numpy, for
# the VTK section of bench/run.sh, and installs Debian's OSMesa (VTK's offscreen
# OpenGL without a display). Not needed by the build or the tests.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
if ! ldconfig -p | grep -q libOSMesa; then
  apt-get install -y libosmesa6
fi
python3 -m venv "$top/bench/.venv"
"$top/bench/.venv/bin/pip" install -q vtk numpy
