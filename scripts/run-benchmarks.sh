#!/usr/bin/env bash
# Runs every benchmark program of a build and writes their JSON results under out/bench/.
set -euo pipefail
build_dir=${1:-build}
out_dir=out/bench
mkdir -p "$out_dir"
status=0
for bench in "$build_dir"/bench/*_bench; do
  [ -x "$bench" ] || continue
  name=$(basename "$bench")
  echo "== $name"
  "$bench" --benchmark_out="$out_dir/$name.json" --benchmark_out_format=json \
    --benchmark_min_time=0.2 || status=1
done
# The detection benchmark once more on the ToF camera's depth (dfpcs/detection_tof.yaml).
if [ -x "$build_dir/bench/detection_bench" ]; then
  echo "== detection_bench (ToF)"
  CDFF_DETECTION_SOURCE=tof "$build_dir/bench/detection_bench" \
    --benchmark_out="$out_dir/detection_bench_tof.json" --benchmark_out_format=json || status=1
fi
# The Python binding's per-call cost and zero-copy transfers, beside the C++ figures of the run.
if [ -d "$build_dir/python/cdff" ]; then
  echo "== python_binding_bench"
  PYTHONPATH="$build_dir/python" /usr/bin/python3 bench/python_binding_bench.py \
    --build "$build_dir" --json "$out_dir/python_binding.json" || status=1
fi
exit $status
