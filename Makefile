# The README's two commands: `make demo` and `make test`. Both set up what is missing first.
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
CMAKE := $(VENV)/bin/cmake
JOBS := 2
# ccache (found by CMakeLists.txt): paths relative to the checkout and no cwd in the hash, so the
# module's build, the C++ tests' and other checkouts on this machine share objects; the cache lives
# in ccache's default folder and survives between runs.
export CCACHE_BASEDIR := $(CURDIR)
export CCACHE_NOHASHDIR := 1
# pyproject.toml's [project] version, the one place it is written.
VERSION = $(shell sed -n 's/^version = "\(.*\)"$$/\1/p' pyproject.toml)
SOURCES := $(shell find cpp python cmake -type f -not -name '*.pyc' 2>/dev/null) CMakeLists.txt pyproject.toml

.PHONY: demo test setup build test-cpp test-cpp-asan test-python bench screenshots wheel addon-zips clean

BLENDER := blender
FIXTURES := blend_fixtures/.fixtures-made

# The main job: the batch command over the .blend fixtures (twist, then bend, on every mesh), with
# the outputs, report.json and a before/after PNG per file in demo_out/batch; the saved lattice and
# Laplacian entries re-evaluated; the core library on a real mesh (OBJ + PNG in
# demo_out/core); and a twisted cage subdivided with OpenSubdiv and checked for smoothness
# (demo_out/subdivision); Sumner's horse poses transferred onto the camel (demo_out/transfer); a
# tube bent by a new Laplacian entry beside Blender's Laplacian Deform (demo_out/laplacian_vs_blender);
# a cage generated around a mesh and bent (demo_out/cage_generation); Blender's Mesh Deform beside
# the Cage entry's Harmonic method, with both binds timed (demo_out/mesh_deform); a folded lattice
# flagged by its certified Jacobian bounds and a volume-preserving lattice edit (demo_out/lattice_bounds).
demo: build $(FIXTURES)
	scripts/deformkit-batch 'blend_fixtures/*.blend' --recipe blend_fixtures/demo_recipe.json \
	    --out demo_out/batch --jobs $(JOBS) --preview
	scripts/deformkit-batch blend_fixtures/lattice_vase.blend --evaluate-saved --out demo_out/lattice --preview
	scripts/deformkit-batch blend_fixtures/laplacian_arm.blend --evaluate-saved --out demo_out/laplacian --preview
	$(PY) scripts/demo.py --out demo_out/core
	$(PY) scripts/demo_subdivision.py --out demo_out/subdivision
	$(PY) scripts/demo_transfer.py --out demo_out/transfer
	$(PY) scripts/demo_laplacian.py --out demo_out/laplacian_vs_blender
	$(PY) scripts/demo_cage_generation.py --out demo_out/cage_generation
	$(PY) scripts/demo_mesh_deform.py --out demo_out/mesh_deform
	$(PY) scripts/demo_lattice_bounds.py --out demo_out/lattice_bounds

$(FIXTURES): blend_fixtures/make_fixtures.py $(VENV)/.deformkit-installed
	@mkdir -p build
	$(BLENDER) -b --factory-startup --python-exit-code 1 -P blend_fixtures/make_fixtures.py -- blend_fixtures \
	    > build/fixtures.log 2>&1 || (cat build/fixtures.log; exit 1)
	@touch $@

test: build test-cpp test-cpp-asan test-python

setup:
	@bash scripts/setup.sh

# Installs the module into .venv exactly as `pip install .` does (a wheel built by
# scikit-build-core), reusing build/wheel so that a rebuild is incremental.
build: setup $(VENV)/.deformkit-installed
$(VENV)/.deformkit-installed: $(SOURCES) requirements-dev.txt
	$(PY) -m pip install -q --disable-pip-version-check --no-build-isolation --no-deps .
	@touch $@

define cpp_tests
	$(CMAKE) -S . -B build/$(1) -G Ninja -DCMAKE_BUILD_TYPE=$(2) -DDEFORMKIT_PYTHON=OFF \
	    -DDEFORMKIT_TESTS=ON $(3) > build/$(1).configure.log || (cat build/$(1).configure.log; exit 1)
	$(CMAKE) --build build/$(1) -j $(JOBS)
	cd build/$(1) && $(abspath $(VENV))/bin/ctest --output-on-failure -j $(JOBS)
endef

test-cpp: setup
	@mkdir -p build
	$(call cpp_tests,cpp-release,Release,)

test-cpp-asan: setup
	@mkdir -p build
	$(call cpp_tests,cpp-asan,RelWithDebInfo,-DDEFORMKIT_SANITIZE=ON)

# On both cores: the tests are independent (each makes its own temporary folders), except the
# packaging ones, which tests/conftest.py keeps on one worker.
test-python: build
	$(PY) -m pytest -q -n $(JOBS) --dist loadgroup tests

bench: build
	bash scripts/setup_bench.sh
	$(PY) benchmarks/bench_barr.py
	$(PY) benchmarks/bench_lattice.py
	$(PY) benchmarks/bench_surface.py
	$(PY) benchmarks/bench_subdivision.py

# Pictures of the add-on's panel (default Properties width) and viewport (Object and Edit Mode), one
# object per entry type, from Blender 3.4's GUI under Xvfb, in build/screenshots; to look at, not a test.
screenshots: build
	bash scripts/setup_screenshots.sh
	$(PY) scripts/screenshots.py --out build/screenshots

# The shipped wheel (docs/install.md): built as `make build` builds it (same build/wheel folder, so
# incrementally), then repaired by auditwheel (every non-system library bundled, the manylinux tag
# set) and given THIRD_PARTY_LICENSES by scripts/repair_wheel.py: dist/deformkit-<v>-cp311-cp311-
# manylinux_*.whl, with dist/auditwheel-show.txt.
wheel: setup
	rm -rf build/wheel-raw
	$(PY) -m pip wheel -q --disable-pip-version-check --no-build-isolation --no-deps -w build/wheel-raw .
	$(PY) scripts/repair_wheel.py build/wheel-raw/deformkit-$(VERSION)-cp311-cp311-linux_x86_64.whl dist

# dist/deformkit-<v>-extension.zip (Blender 4.2+) and dist/deformkit_addon-<v>-legacy.zip (3.x).
addon-zips: wheel
	$(PY) scripts/package_addon.py $$(ls dist/deformkit-$(VERSION)-cp311-cp311-manylinux_*.whl) dist

clean:
	rm -rf build dist demo_out $(VENV)/.deformkit-installed blend_fixtures/*.blend $(FIXTURES)
