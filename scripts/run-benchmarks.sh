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
exit $status
