#!/usr/bin/env bash
# make fuzz: builds the MCAP reader fuzzer with clang (libFuzzer, AddressSanitizer,
# UndefinedBehaviorSanitizer) and runs it.
#   FUZZ_SECONDS   how long to run (default 600)
#   FUZZ_JOBS      parallel fuzzing processes (default 1)
#   FUZZ_BUILD_DIR build directory (default build-fuzz)
# Findings (crash-*, leak-*, timeout-*, oom-*) are written to $FUZZ_BUILD_DIR/findings/ and the
# script exits non-zero; the corpus grows in $FUZZ_BUILD_DIR/corpus/ (fuzz/corpus/ is the seed).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${FUZZ_SECONDS:-600}
jobs=${FUZZ_JOBS:-1}
build=${FUZZ_BUILD_DIR:-build-fuzz}

if ! command -v clang++ >/dev/null 2>&1; then
  echo "fuzz: clang++ not found; install it with 'sudo bash scripts/install-deps.sh fuzz'" >&2
  exit 1
fi
bash scripts/install-deps.sh fuzz
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DCDFF_FUZZ=ON \
  -DCDFF_SANITIZE=address,undefined -DCDFF_BUILD_TESTS=OFF -DCDFF_BUILD_BENCH=OFF \
  > "$build.configure.log" 2>&1 || { cat "$build.configure.log"; exit 1; }
cmake --build "$build" -j "${FUZZ_BUILD_JOBS:-2}" --target mcap_reader_fuzz

mkdir -p "$build/corpus" "$build/findings"
cp -n fuzz/corpus/* "$build/corpus/" 2>/dev/null || true
echo "fuzz: running mcap_reader_fuzz for ${seconds} s (${jobs} job(s))"
status=0
parallel=()
if [ "$jobs" -gt 1 ]; then parallel=(-fork="$jobs"); fi
"$build/fuzz/mcap_reader_fuzz" "$build/corpus" -max_total_time="$seconds" "${parallel[@]}" \
  -max_len=65536 -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
  -artifact_prefix="$build/findings/" || status=$?
if ls "$build/findings/"* >/dev/null 2>&1; then
  echo "fuzz: FINDINGS in $build/findings/:" >&2
  ls -l "$build/findings/" >&2
  exit 1
fi
if [ "$status" -ne 0 ]; then
  echo "fuzz: the fuzzer exited with status $status" >&2
  exit "$status"
fi
echo "fuzz: no finding in ${seconds} s; corpus: $(ls "$build/corpus" | wc -l) inputs"
