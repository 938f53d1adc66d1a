#!/usr/bin/env bash
# Builds what the GPU checks of issue 7 need and packs it for the lent GPU machine (tool `device`, see
# docs/gpu.md), which has CUDA 13 and Python 3.12 with NumPy but none of caustica's libraries and no network:
#   .gpu-bundle/bundle.tar.xz   bin/caustica_tests, bin/caustica_bench_bvh (CUDA build, sm_80 + sm_90),
#                        python/caustica (the package with its extension built for CPython 3.12),
#                        lib/ (every shared library they load except glibc's), run-gpu-checks.sh
# Needs a CPython 3.12 with headers here (PYTHON312, default: pyenv's) and `make build` done once (deps).
# Usage: scripts/gpu-bundle.sh        then, through the device tool, carry .gpu and run
#        `tar xJf .gpu-bundle/bundle.tar.xz -C /tmp && /tmp/bundle/run-gpu-checks.sh` (carry .gpu-bundle only:
#        .gpu holds the build's Python 3.12 environment and is far over the device tool's 64 MiB)
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
PY312=${PYTHON312:-$(ls -d /root/.pyenv/versions/3.12*/bin/python3.12 2>/dev/null | head -n1)}
[ -x "$PY312" ] || { echo "gpu-bundle: no CPython 3.12 (set PYTHON312)"; exit 2; }
NVCC=$(ls "$ROOT"/.venv/lib/python3*/site-packages/nvidia/cu13/bin/nvcc | head -n1)
GITDIR=$(git rev-parse --git-dir)
mkdir -p "$GITDIR/info"
for d in /.gpu/ /.gpu-bundle/; do
  grep -qx "$d" "$GITDIR/info/exclude" 2>/dev/null || echo "$d" >> "$GITDIR/info/exclude"
done
mkdir -p .gpu
if [ ! -x .gpu/venv312/bin/python ]; then
  "$PY312" -m venv .gpu/venv312
  .gpu/venv312/bin/pip install -q nanobind scikit-build-core numpy
fi
.venv/bin/cmake -S . -B build/py312 -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_MAKE_PROGRAM="$ROOT/.venv/bin/ninja" \
  -DPython_EXECUTABLE="$ROOT/.gpu/venv312/bin/python" -DCAUSTICA_CUDA=ON -DCMAKE_CUDA_COMPILER="$NVCC" \
  "-DCMAKE_CUDA_ARCHITECTURES=80;90" > .gpu/configure.log
.venv/bin/cmake --build build/py312 -j "${JOBS:-2}" --target _native caustica_tests caustica_bench_bvh

B=.gpu/bundle
rm -rf "$B" && mkdir -p "$B/bin" "$B/lib" "$B/python"
cp build/py312/caustica_tests build/py312/caustica_bench_bvh "$B/bin/"
cp -r python/caustica "$B/python/"
# FLIP for `caustica study realtime --device cuda` (the GPU machine's Python has numpy and matplotlib, not this).
.gpu/venv312/bin/pip install -q --no-deps --target "$B/python" flip-evaluator==1.7
find "$B/python" -name __pycache__ -prune -exec rm -rf {} +
cp build/py312/_native*.so "$B/python/caustica/"
strip "$B"/bin/caustica_* "$B"/python/caustica/_native*.so
# Shared libraries: all but glibc's own (the machine's newer glibc runs binaries built for 2.36).
for f in "$B"/bin/* "$B"/python/caustica/_native*.so; do
  ldd "$f" | awk '/=> \//{print $3}'
done | sort -u | grep -vE '/(libc|libm|libdl|librt|libpthread|ld-linux[^/]*)\.so' | while read -r lib; do
  cp -L "$lib" "$B/lib/"
done
cat > "$B/run-gpu-checks.sh" <<'EOF'
#!/usr/bin/env bash
# On the GPU machine, from the repository root: every GPU check of issue 7 (docs/gpu.md). Logs to $OUT.
set -uo pipefail
B=/tmp/bundle
export LD_LIBRARY_PATH=$B/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH} PYTHONPATH=$B/python PYTHONUNBUFFERED=1
export CAUSTICA_BIN=$B/bin/caustica
OUT=${OUT:-/tmp/out}; mkdir -p "$OUT"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv | tee "$OUT/gpu.txt"
python3 -c "import caustica; print(caustica.devices())" 2>&1 | tee -a "$OUT/gpu.txt"
step() { echo "== $*"; "$@"; echo "== exit $?"; }
step $B/bin/caustica_tests --gtest_filter='Cuda*:Wavefront*:CpuBackend*' 2>&1 | tee "$OUT/gtest.txt"
step python3 -m pytest -q -p no:cacheprovider tests/python/test_wavefront.py tests/python/test_cli.py tests/python/test_motion_blur.py tests/python/test_restir.py tests/python/test_light_sampler.py tests/python/test_study.py tests/python/test_media_photons.py tests/python/test_media_grid.py tests/python/test_media_grid_colour.py tests/python/test_media_emission.py tests/python/test_media_bidir.py tests/python/test_media_restir.py tests/python/test_hide_emitters.py tests/python/test_vertex_colors.py tests/python/test_principled.py tests/python/test_camera_film.py tests/python/test_crop_clip.py -k "gpu or device or cuda" 2>&1 | tee "$OUT/pytest.txt"
step compute-sanitizer --tool memcheck --error-exitcode 1 $B/bin/caustica_tests \
  --gtest_filter='Cuda.SwitchesChangeNothingOnTheGpu' 2>&1 | tail -n 40 | tee "$OUT/memcheck.txt"
for args in "--integrator path --sort-materials" "--integrator sppm --photons 5000" \
            "--integrator pppm --photons 5000 --stochastic-hash" "--integrator vcm --photons 2000" \
            "--integrator ppm --photons 5000" "--integrator pm --photons 5000" \
            "--integrator sppm --photons 4096 --photon-sampling adaptive"; do
  step compute-sanitizer --tool memcheck --error-exitcode 1 python3 -m caustica.cli render smallvcm-spheres \
    --device cuda --spp 2 --width 64 --height 48 --quiet -o /tmp/memcheck.exr $args 2>&1 | tail -n 20 \
    | tee -a "$OUT/memcheck.txt"
done
step $B/bin/caustica_bench_bvh cornell 1920 1080 2>&1 | tee "$OUT/bvh.txt"
step python3 bench/bench_gpu.py --no-results 2>&1 | tee "$OUT/bench.txt"
# The real-time study on the GPU (docs/realtime-study.md): spp per FLIP threshold, throughput at 1080p.
step timeout 300 python3 -m caustica.cli study realtime cornell --device cuda --max-spp 64 --seeds 2 \
  --ref-spp 4096 --out /tmp/realtime 2>&1 | tail -n 40 | tee "$OUT/study.txt"
cp /tmp/realtime/report.md "$OUT/study-report.md"  # the device tool returns at most 8 files from $OUT
EOF
printf '#!/bin/sh\nexec python3 -m caustica.cli "$@"\n' > "$B/bin/caustica"
chmod +x "$B/run-gpu-checks.sh" "$B/bin/caustica"
mkdir -p .gpu-bundle
tar -C .gpu -cJf .gpu-bundle/bundle.tar.xz bundle
du -sh "$B" .gpu-bundle/bundle.tar.xz
