#!/usr/bin/env bash
# The DDS transport's latency (bench/dds_bench.cpp) and Cyclone's own ddsperf with the same
# payloads, in one run on this machine: ddsperf pings a ddsperf pong on loopback with the
# configuration the CDFF gives its domains (src/cdff/dds/participant.hpp), for the image's
# 2 004 016 bytes and the cloud's 660 000 (30 000 points of 22 bytes).
# Then the throughput peer (below).
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
# Throughput peer: the sensor suite's load (two 2 004 016-byte images at 25 Hz each, i.e. 50 Hz,
# and a 660 000-byte scan at 10 Hz) from two ddsperf publishers to one ddsperf subscriber; -c
# makes each report its threads' CPU (user%+system%: pub, recvUC, ...).
ddsperf -D 7 -i "$domain" -c sub >/tmp/ddsperf_sub.$$ 2>&1 &
sub=$!
sleep 0.5
ddsperf -D 6 -i "$domain" pub 10Hz size 660000 >/dev/null 2>&1 &
lidar=$!
ddsperf -D 6 -i "$domain" -c pub 50Hz size 2004016 >/tmp/ddsperf_pub.$$ 2>&1 || true
wait "$lidar" "$sub" || true
echo "ddsperf sub (50 Hz x 2 MB + 10 Hz x 0.66 MB), its last reports:"
grep -v "@" /tmp/ddsperf_sub.$$ | grep -E "rss:|size" | tail -3
echo "ddsperf pub 50 Hz x 2 MB, its last report of its own threads:"
grep -v "@" /tmp/ddsperf_pub.$$ | grep "rss:" | tail -1
rm -f /tmp/ddsperf_sub.$$ /tmp/ddsperf_pub.$$
