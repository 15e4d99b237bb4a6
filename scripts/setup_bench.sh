#!/usr/bin/env bash
# Benchmark-only dependencies (not needed to build or test deformkit; `make bench` runs this):
# Debian's libcgal-dev, for the CGAL Surface_mesh_deformation comparison in
# benchmarks/bench_surface.py (built from benchmarks/cgal_arap into build/bench-cgal). CGAL 5.x is
# header-only; its Surface_mesh_deformation uses Eigen (libeigen3-dev, installed by scripts/setup.sh).
# Safe to run every time; it does nothing when all is in place.
set -euo pipefail
cd "$(dirname "$0")/.."

# Debian package -> upstream version prefix the benchmark is written and measured against
# (Debian bookworm's libcgal-dev is 5.5.1-2).
declare -A APT_PINS=(
  [libcgal-dev]=5.5.1
)
# What the cgal_arap build needs besides CGAL: a C++ compiler and Eigen 3.
APT_BUILD=(build-essential libeigen3-dev)

source scripts/apt_pins.sh
apt_install_pinned APT_PINS "${APT_BUILD[@]}"
