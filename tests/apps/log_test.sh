#!/usr/bin/env bash
# `cdff log info | cat | cut`: output, exit statuses, and bad input (missing, empty, foreign,
# truncated, bit-flipped files), which must give the byte offset and a non-zero status.
# usage: log_test.sh CDFF MCAP_INTEROP WORK_DIR
set -u
cdff=$1
samples=$2
work=$3
rm -rf "$work"
mkdir -p "$work"

source "$(dirname "${BASH_SOURCE[0]}")/check.sh"

"$samples" write "$work" >/dev/null || { echo "FAIL: cannot write the sample files"; exit 1; }
good=$work/cdff_lz4.mcap

check log-help 0 'info.*' -- "$cdff" log --help
check log-info-help 0 '--quick' -- "$cdff" log info --help
check log-cat-help 0 '--channel' -- "$cdff" log cat --help
check log-cut-help 0 '--output' -- "$cdff" log cut --help
check log-unknown-subcommand 2 "unknown subcommand 'lst'" -- "$cdff" log lst
check log-info-no-file 2 'FILE' -- "$cdff" log info
check log-cut-no-output 2 'output' -- "$cdff" log cut "$good"

check info-channels 0 'channels: +27' -- "$cdff" log info "$good"
check info-rate 0 '/chaser/imu +ImuSample +cdff.ImuSample +json +120 +100.00 Hz' -- "$cdff" log info "$good"
check info-compression 0 'compression: lz4 \(40 chunks' -- "$cdff" log info "$good"
check info-time 0 'duration 1.190 s' -- "$cdff" log info "$good"
check info-checked 0 'every chunk read, CRCs match' -- "$cdff" log info "$good"
check info-quick 0 'messages: +431 \(from the statistics record\)' -- "$cdff" log info --quick "$good"
check info-json 0 '^ok$' -- bash -c "'$cdff' log info --json '$good' | python3 -c 'import json,sys; d=json.load(sys.stdin); assert d[\"messages\"] == 431 and len(d[\"channels\"]) == 27 and d[\"damage\"] == []; print(\"ok\")'"

check cat-lines 0 '^3$' -- bash -c "'$cdff' log cat '$good' -c /chaser/imu -n 3 | python3 -c 'import json,sys; l=[json.loads(x) for x in sys.stdin]; assert all(m[\"channel\"] == \"/chaser/imu\" and m[\"type\"] == \"ImuSample\" for m in l); print(len(l))'"
check cat-summarised 0 '"data":\{"\$bytes":960,"head":"[0-9a-f]{12}"' -- "$cdff" log cat "$good" -c /chaser/camera/left/image -n 1
check cat-window 0 '^31$' -- bash -c "'$cdff' log cat '$good' -c /chaser/imu --start 0.3 --end 0.6 | wc -l"
check cat-unknown-channel 1 "no channel '/nope'.*channels are: .*/chaser/imu" -- "$cdff" log cat "$good" -c /nope
check cat-bad-window 1 'before --start' -- "$cdff" log cat "$good" --start 2 --end 1

check cut 0 'wrote 35 messages on 2 channels' -- "$cdff" log cut "$good" -o "$work/cut.mcap" --start 0.3 --end 0.6 -c /chaser/imu -c /truth/target_state --compression zstd
check cut-result 0 '/chaser/imu .* 31 ' -- "$cdff" log info "$work/cut.mcap"
check cut-onto-input 1 'also an input' -- "$cdff" log cut "$good" -o "$good"
check cut-bad-compression 2 'compression' -- "$cdff" log cut "$good" -o "$work/x.mcap" --compression gzip

# Bad input.
check missing-file 1 "cannot open '$work/none.mcap'" -- "$cdff" log info "$work/none.mcap"
: > "$work/empty.mcap"
check zero-length 1 'empty \(0 bytes\)' -- "$cdff" log info "$work/empty.mcap"
printf '\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x10' > "$work/image.mcap"
check png-renamed 1 'not an MCAP file: bytes 0-7 are 89 50 4E 47.*PNG' -- "$cdff" log cat "$work/image.mcap"
check directory 1 'not a regular file' -- "$cdff" log info "$work"

size=$(stat -c %s "$good")
head -c $((size / 2)) "$good" > "$work/truncated.mcap"
check truncated-info 1 "is damaged: byte offset [0-9]+: truncated" -- "$cdff" log info "$work/truncated.mcap"
check truncated-cat 1 "byte offset [0-9]+" -- "$cdff" log cat "$work/truncated.mcap" -c /chaser/imu
check truncated-cat-keeps-data 0 '^[1-9][0-9]*$' -- bash -c "'$cdff' log cat '$work/truncated.mcap' -c /chaser/imu 2>/dev/null | wc -l"
check truncated-cut-repairs 1 'input is damaged.*intact messages were written' -- "$cdff" log cut "$work/truncated.mcap" -o "$work/repaired.mcap"
check repaired-is-sound 0 'every chunk read, CRCs match' -- "$cdff" log info "$work/repaired.mcap"

python3 - "$good" "$work/flipped.mcap" <<'PY'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
data[len(data) // 3] ^= 0x04  # inside a chunk's compressed records
open(sys.argv[2], "wb").write(data)
PY
check flipped-info 1 "is damaged: byte offset [0-9]+: .*(CRC mismatch|lz4)" -- "$cdff" log info "$work/flipped.mcap"
check flipped-cat 1 "byte offset [0-9]+" -- "$cdff" log cat "$work/flipped.mcap"

echo "$failures failed"
[ "$failures" -eq 0 ]
