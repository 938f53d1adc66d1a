# caustica: `make render` and `make test` install what is missing, build, and run.
VENV    := .venv
PY      := $(VENV)/bin/python
NVCC     = $(abspath $(shell ls $(VENV)/lib/python3*/site-packages/nvidia/cu13/bin/nvcc 2>/dev/null | head -n1))
SCENE   ?= smallvcm-spheres
SPP     ?= 64
JOBS    ?= $(shell nproc)

FUZZ_SECONDS ?= 3600
FUZZ_SEED    ?= 1

.PHONY: all deps build render test test-cpp test-python cuda-check gpu-bundle fuzz-build fuzz fuzz-short bench clean

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

# The CUDA backend is compiled into the module by `make build` (nvcc 13.0 from PyPI, sm_80 and sm_90,
# warnings as errors): the backend primitives and the wavefront drivers (path, sppm/ppm/pppm/pm, light/bdpt/bpm/vcm/upg)
# with every stage function they run. No GPU is needed to compile; this checks that it was.
cuda-check: build
	@grep -q '^CAUSTICA_CUDA:BOOL=ON' build/py/CMakeCache.txt || \
	  (echo "cuda-check: build/py has no CUDA backend (CUDA=$(CUDA), nvcc: '$(NVCC)')"; exit 1)
	@echo "cuda-check: the CUDA backend compiled for sm_$$(grep '^CMAKE_CUDA_ARCHITECTURES' build/py/CMakeCache.txt | cut -d= -f2 | sed 's/;/, sm_/g') with $$($(NVCC) --version | tail -n 2 | head -n 1)"

# The GPU checks' bundle for a lent GPU machine (docs/gpu.md): tests, benchmarks and a CPython 3.12 module
# with their shared libraries in .gpu-bundle/bundle.tar.xz (needs a CPython 3.12 with headers: PYTHON312).
gpu-bundle: deps
	bash scripts/gpu-bundle.sh

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
	rm -rf build out build-fuzz.log fuzz-findings
