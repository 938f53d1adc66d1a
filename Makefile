# caustica: `make render` and `make test` install what is missing, build, and run.
VENV    := .venv
PY      := $(VENV)/bin/python
NVCC     = $(abspath $(shell ls $(VENV)/lib/python3*/site-packages/nvidia/cu13/bin/nvcc 2>/dev/null | head -n1))
SCENE   ?= smallvcm-spheres
SPP     ?= 64
JOBS    ?= $(shell nproc)

FUZZ_SECONDS ?= 3600
FUZZ_SEED    ?= 1

.PHONY: all deps build render test test-cpp test-python cuda-check fuzz-build fuzz fuzz-short bench clean

all: build

deps:
	@bash scripts/install-deps.sh

# The CUDA backend is built when nvcc from PyPI is there (scripts/install-deps.sh installs it); CUDA=0
# builds the CPU-only module. CUDA_ARCHS: the GPUs to compile for (Ampere and Hopper).
CUDA       ?= 1
CUDA_ARCHS ?= 80;90
CUDA_ARGS   = $(if $(and $(filter 1,$(CUDA)),$(NVCC)),-DCAUSTICA_CUDA=ON -DCMAKE_CUDA_COMPILER=$(NVCC) \
              -DCUDAToolkit_ROOT=$(abspath $(dir $(NVCC))..) "-DCMAKE_CUDA_ARCHITECTURES=$(CUDA_ARCHS)",-DCAUSTICA_CUDA=OFF)

build: deps
	CMAKE_ARGS='$(CUDA_ARGS)' CMAKE_BUILD_PARALLEL_LEVEL=$(JOBS) $(PY) -m pip install -q --no-build-isolation --no-deps -e .

render: build
	@mkdir -p out
	$(VENV)/bin/caustica render $(SCENE) --spp $(SPP) -o out/default.exr -o out/default.png

test: build cuda-check test-cpp test-python fuzz-short

test-cpp:
	cd build/py && ctest --output-on-failure -j 1

test-python:
	$(PY) -m pytest -q tests/python

# Compiles the shared per-ray code and the path tracer's stage functions with
# nvcc (CUDA 13.0 from PyPI): compile only, no GPU needed.
cuda-check: deps
	$(VENV)/bin/cmake -S . -B build/cuda -G Ninja -DCAUSTICA_CUDA_CHECK_ONLY=ON \
	  -DCMAKE_CUDA_COMPILER=$(NVCC) -DCUDAToolkit_ROOT=$(dir $(NVCC)).. -DCMAKE_MAKE_PROGRAM=$(abspath $(VENV)/bin/ninja) > build-cuda.log 2>&1 \
	  || (cat build-cuda.log; exit 1)
	$(VENV)/bin/cmake --build build/cuda
	@echo "cuda-check: device code compiles with $$($(NVCC) --version | tail -n 2 | head -n 1)"

# The scene-loader fuzzer under AddressSanitizer + UBSan (tests/fuzz, docs/fuzzing.md):
# `make test` runs it for a minute; `make fuzz` for FUZZ_SECONDS (default an hour).
fuzz-build: deps
	$(VENV)/bin/cmake -S . -B build/fuzz -G Ninja -DCAUSTICA_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  -DCMAKE_MAKE_PROGRAM=$(abspath $(VENV)/bin/ninja) > build-fuzz.log 2>&1 || (cat build-fuzz.log; exit 1)
	$(VENV)/bin/cmake --build build/fuzz -j $(JOBS)

fuzz: fuzz-build
	ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 build/fuzz/caustica_fuzz tests/fuzz/corpus $(FUZZ_SECONDS) $(FUZZ_SEED) fuzz-findings

fuzz-short: fuzz-build
	ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 build/fuzz/caustica_fuzz tests/fuzz/corpus 60 $(FUZZ_SEED) fuzz-findings

bench: build
	$(PY) bench/run.py $(BENCH_ARGS)

clean:
	rm -rf build out build-cuda.log build-fuzz.log fuzz-findings
