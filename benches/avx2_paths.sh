#!/usr/bin/env bash
# Issue 18's one-core rows with AVX2 code paths only, on a CPU that also has AVX-512.
#
#     bash benches/avx2_paths.sh [RUNS] 2>&1 | tee avx2-$(date +%F).log
#     bash benches/avx2_paths.sh --check    # only prepare the patched copy (CI: still applies?)
#
# The issue's targets name an AVX2-only CPU. On an AVX-512 CPU (this project's machines) four
# things pick 512-bit code at run time, and none has a switch:
#   - faer's matrix products (`private-gemm-x86`): `is_x86_feature_detected!("avx512f")`, in
#     faer's `linalg/matmul/{mod,triangular,internal/mod}.rs`;
#   - pulp's dispatch (faer's element-wise kernels, and ours): only with pulp's `x86-v4`
#     feature, which our Cargo.toml turns on;
#   - OpenBLAS (GPy's side): its own detection, overridden by `OPENBLAS_CORETYPE=Haswell`;
#   - glibc's memcpy and memset (both sides): turned off by `GLIBC_TUNABLES`.
# This script builds a copy of HEAD in a temporary directory with faer's three checks patched
# to `false` (a copy of faer from cargo's registry, used through `[patch.crates-io]`) and
# without pulp's `x86-v4`, then runs the one-core rows: `step_times` (one space's evaluation
# against its floor) and `bench_vs_gpy.py --evaluation-only`, GPy on Haswell kernels.
# With `perf` installed it also checks that no sample of an evaluation falls in a 512-bit
# kernel.
#
# This is a Zen 4 core running AVX2 code, not an AVX2-only CPU: Zen 4 executes 512-bit
# instructions as two 256-bit halves, so AVX2 code runs nearly as fast on it, and an AVX2-only
# CPU has other absolute speeds. The figures say what our code does without AVX-512; the
# reference machine settles the rest.
#
# The comparison with GPy runs RUNS times (default 3): one run's ratios move by 10-15 % on a
# shared machine.
#
# Needs what `benches/run_all.sh` needs (GPy, threadpoolctl, maturin, in the active Python).
# About 3 minutes on 2 cores when the target directory is warm; the first build takes longer.
set -euo pipefail
check_only=false
runs=3
case "${1:-}" in
  --check) check_only=true ;;
  "") ;;
  *) runs="$1" ;;
esac
root="$(cd "$(dirname "$0")/.." && pwd)"
work="$(mktemp -d "${TMPDIR:-/tmp}/sgplvm-avx2.XXXXXX")"
trap 'rm -rf "$work"' EXIT
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}/avx2-paths"
export GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX512F,-AVX512VL,-AVX512BW,-AVX512DQ,-AVX512CD
one_core=(env RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1)

faer_version="$(cd "$root" && cargo tree -p sgplvm-core -e normal -i faer --depth 0 | awk '{print $2; exit}' | tr -d v)"
faer_src="$(cd "$root" && cargo metadata --format-version 1 | python3 -c "
import json, sys
m = json.load(sys.stdin)
print(next(p['manifest_path'] for p in m['packages'] if p['name'] == 'faer' and p['version'] == '$faer_version'))
" | xargs dirname)"
echo "== faer $faer_version from $faer_src, its AVX-512 checks patched to false"
cp -r "$faer_src" "$work/faer"
chmod -R u+w "$work/faer"
checks=$(grep -rl 'avx512f' "$work/faer/src/linalg/matmul")
perl -0pi -e 's/std::arch::is_x86_feature_detected!\(\s*"avx512f"\s*,?\s*\)/false/g' $checks
left=$(grep -rn '"avx512f"' "$work/faer/src" || true)
if [ -n "$left" ]; then
  echo "an AVX-512 check of faer was not patched (faer's source changed?):"; echo "$left"; exit 1
fi

echo "== HEAD ($(git -C "$root" rev-parse --short HEAD)) without pulp's x86-v4"
mkdir "$work/src"
git -C "$root" archive HEAD | tar -x -C "$work/src"
grep -q 'pulp = { version = "[^"]*", features = \["x86-v4"\] }' "$work/src/Cargo.toml" || {
  echo "Cargo.toml's pulp line changed: update this script"; exit 1; }
sed -i 's/\(pulp = { version = "[^"]*"\), features = \["x86-v4"\] }/\1 }/' "$work/src/Cargo.toml"
if (cd "$work/src" && cargo tree -q -e features -i pulp | grep -q 'x86-v4'); then
  echo "pulp's x86-v4 is still turned on by another crate:"; exit 1
fi
printf '\n[patch.crates-io]\nfaer = { path = "%s" }\n' "$work/faer" >> "$work/src/Cargo.toml"
cd "$work/src"
cargo tree -q -p sgplvm-core -e normal -i faer --depth 0 | grep -q "($work/faer)" || {
  echo "the patched faer is not the one sgplvm-core builds with"; exit 1; }
if $check_only; then
  echo "the AVX2-only copy can be built (faer patched, pulp without x86-v4)"
  exit 0
fi
core_tests="$(cargo test -q --release -p sgplvm-core --lib --no-run --message-format json 2>/dev/null |
  python3 -c "
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get('reason') == 'compiler-artifact' and m.get('executable') and m['target']['name'] == 'sgplvm_core':
        print(m['executable'])
")"
maturin build -q --release -m crates/sgplvm-py/Cargo.toml --out "$work/wheel" >/dev/null
mkdir "$work/module"
python3 -m zipfile -e "$work"/wheel/*.whl "$work/module"
export PYTHONPATH="$work/module${PYTHONPATH:+:$PYTHONPATH}"
python3 -c "import sgplvm, sys; assert sgplvm.__file__.startswith('$work'), sgplvm.__file__"

lscpu | grep -E "Model name"
uptime
if command -v perf >/dev/null; then
  echo "== samples of one space's evaluations (N = 300) in 512-bit code (expected: none)"
  STEP_N=300 "${one_core[@]}" perf record -q -F 5000 -o "$work/perf.data" \
    "$core_tests" step_times --ignored --nocapture >/dev/null 2>&1
  perf report -i "$work/perf.data" --no-children --sort dso,sym 2>/dev/null |
    grep -iE 'simd512|avx512|v4::|_v4' | head -5 || echo "none"
fi
echo "== one space's evaluation step by step, one core (fastest of 20 each)"
for n in 300 1000; do
  STEP_N=$n "${one_core[@]}" "$core_tests" step_times --ignored --nocapture | grep ' us '
done
echo "== against GPy (OpenBLAS on its Haswell kernels), one core each"
OPENBLAS_CORETYPE=Haswell python3 -c "
import numpy, threadpoolctl
print('BLAS:', [(i['internal_api'], i.get('architecture')) for i in threadpoolctl.threadpool_info()])"
for run in $(seq "$runs"); do
  echo "-- run $run of $runs"
  OPENBLAS_CORETYPE=Haswell "${one_core[@]}" python3 "$root/benches/bench_vs_gpy.py" --evaluation-only
done
uptime
