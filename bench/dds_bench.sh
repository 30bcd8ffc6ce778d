#!/usr/bin/env bash
# The DDS transport's latency (bench/dds_bench.cpp) and Cyclone's own ddsperf with the same
# payloads, in one run on this machine: ddsperf pings a ddsperf pong on loopback with the
# configuration the CDFF gives its domains (src/cdff/dds/participant.hpp), for the image's
# 2 004 016 bytes and the cloud's 660 000 (30 000 points of 22 bytes).
# usage: bench/dds_bench.sh [BUILD_DIR]
set -euo pipefail
build=${1:-build}
"$build/bench/dds_bench" --benchmark_counters_tabular=true
CYCLONEDDS_URI=$("$build/bench/dds_bench" --print-config)
export CYCLONEDDS_URI
domain=$((($$ % 200) + 1))
for size in 2004016 660000; do
  ddsperf -D 7 -i "$domain" pong >/dev/null 2>&1 &
  pong=$!
  sleep 0.5
  echo "ddsperf -i $domain ping size $size (pong in another process), last report:"
  ddsperf -D 6 -i "$domain" ping size "$size" 2>&1 | grep "size $size" | tail -1
  wait "$pong" || true
done
