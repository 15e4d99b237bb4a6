# The README's two commands: `make demo` and `make test`. Both set up what is missing first.
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
CMAKE := $(VENV)/bin/cmake
JOBS := 2
SOURCES := $(shell find cpp python -type f -not -name '*.pyc' 2>/dev/null) CMakeLists.txt pyproject.toml

.PHONY: demo test setup build test-cpp test-cpp-asan test-python bench wheel clean

demo: build
	$(PY) scripts/demo.py --out demo_out

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

test-python: build
	$(PY) -m pytest -q tests

bench: build
	$(PY) benchmarks/bench_barr.py

wheel: setup
	$(PY) -m pip wheel --no-build-isolation --no-deps -w dist .

clean:
	rm -rf build dist demo_out $(VENV)/.deformkit-installed
