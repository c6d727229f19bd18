#!/usr/bin/env bash
# Every figure of BENCHMARKS.md's "Per core, set_params and time to solution (issue 18)"
# section, in one command, on a quiet machine:
#
#     bash benches/run_all.sh 2>&1 | tee bench-$(date +%F).log
#
# Needs the Python module built in the active environment (`maturin develop --release`), GPy
# and threadpoolctl. About 15–20 minutes on 2 cores (GPy's time to solution at N = 1000
# dominates).
set -euo pipefail
cd "$(dirname "$0")/.."
one_core=(env RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1)
lscpu | grep -E "Model name|Flags" | sed 's/\(Flags:\).*\(avx2\).*/\1 … \2 …/'
grep -o 'avx512[a-z]*' /proc/cpuinfo | sort -u | tr '\n' ' '; echo
uptime

echo "== one space's evaluation step by step, one core (fastest of 20 each)"
for n in 300 1000; do
  STEP_N=$n "${one_core[@]}" cargo test --release -q -p sgplvm-core --lib step_times -- --ignored --nocapture | grep ' us '
done

echo "== criterion: evaluation against its floor, set_params + evaluate against evaluate"
"${one_core[@]}" cargo bench -q -p sgplvm-core --bench model -- --warm-up-time 1 --measurement-time 3 'evaluation|set_params' | grep -E '^(evaluation|set_params)|time:'
cargo bench -q -p sgplvm-core --bench model -- --warm-up-time 1 --measurement-time 3 'evaluation' | grep -E '^evaluation|time:'

echo "== against GPy, one core each"
"${one_core[@]}" python benches/bench_vs_gpy.py --evaluation-only
echo "== against GPy, default threads (ours) and GPy's fastest"
python benches/bench_vs_gpy.py
uptime
