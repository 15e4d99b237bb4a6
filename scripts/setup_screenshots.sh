#!/usr/bin/env bash
# Screenshot-only dependencies (not needed to build or test deformkit; `make screenshots` runs
# this): an X server without a screen (Xvfb) for Blender's GUI; the GL driver is Mesa's software
# llvmpipe (libgl1-mesa-dri). screenshots.py starts Xvfb itself (no xvfb-run, so no xauth).
# Safe to run every time; it does nothing when all is in place.
set -euo pipefail
cd "$(dirname "$0")/.."

# Debian package -> upstream version prefix the screenshots are taken with (Debian bookworm).
declare -A APT_PINS=(
  [xvfb]=21.1.7
  [libgl1-mesa-dri]=22.3.6
  [blender]=3.4.1
)

source scripts/apt_pins.sh
apt_install_pinned APT_PINS
