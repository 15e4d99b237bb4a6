#!/usr/bin/env bash
# Installs whatever is missing on a fresh machine: Debian packages (apt-get) and the pinned
# PyPI packages in .venv. Safe to run every time; it does nothing when all is in place.
set -euo pipefail
cd "$(dirname "$0")/.."

# Debian package -> upstream version prefix the project is built and tested against. CHOLMOD
# (SuiteSparse) factorises the surface deformers' systems; OpenBLAS replaces the reference BLAS
# under its supernodal factorisation (Debian's alternatives pick it once installed). The serial
# build: a threaded one spins on sched_yield between calls, taking a core from deformkit's own
# OpenMP threads on a 2-core machine.
# xvfb (xvfb-run, with xauth): a Blender 3.4 window without a screen, for the Ctrl+A test.
# ccache: builds share objects across `make test`'s three build folders and across runs.
# CGAL (with GMP and MPFR): exact predicates for the cage's self-intersection test.
declare -A APT_PINS=(
  [libeigen3-dev]=3.4.0
  [libosd-dev]=3.5.0
  [libhwy-dev]=1.0.3
  [libgtest-dev]=1.12.1
  [blender]=3.4.1
  [libsuitesparse-dev]=5.12.0
  [libnanoflann-dev]=1.4.3
  [libopenblas0-serial]=0.3.21
  [xvfb]=21.1.7
  [xauth]=1.1.2
  [ccache]=4.8+really4.7
  [libcgal-dev]=5.5
  [libgmp-dev]=6.2
  [libmpfr-dev]=4.2
)
# Shared libraries that the PyPI bpy wheel loads on a headless machine; numpy and pytest for Blender 3.4;
# chattr (e2fsprogs) for the batch tests' read-only folder, which root cannot otherwise make;
# openssl for the TLS cluster tests' certificates, made as docs/batch.md shows.
APT_RUNTIME=(python3-pytest libgl1 libegl1 libglib2.0-0 libsm6 libxext6 libxrender1 libxi6 libxxf86vm1
             libxfixes3 libxkbcommon0 build-essential python3-numpy e2fsprogs openssl)

source scripts/apt_pins.sh
apt_install_pinned APT_PINS "${APT_RUNTIME[@]}"

PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv with $($PYTHON --version)"
  "$PYTHON" -m venv .venv
fi
stamp=.venv/.requirements.sha256
want=$(sha256sum requirements-dev.txt | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  echo "setup: installing pinned PyPI packages into .venv"
  .venv/bin/python -m pip install -q --disable-pip-version-check -r requirements-dev.txt
  echo "$want" > "$stamp"
fi
