#!/usr/bin/env bash
# The `cdff` command: exit statuses, listings and usage errors.
set -u
cdff=$1
source "$(dirname "${BASH_SOURCE[0]}")/check.sh"
check version 0 '^cdff [0-9]+\.[0-9]+\.[0-9]+' -- "$cdff" --version
check help 0 'dfn' -- "$cdff" --help
check no-subcommand 2 'subcommand' -- "$cdff"
check unknown-subcommand 2 'frobnicate' -- "$cdff" frobnicate
check unknown-dfn-subcommand 2 "unknown subcommand 'lst'.*expected one of \\{list, info\\}" -- "$cdff" dfn lst
check unknown-option 2 'bogus' -- "$cdff" dfn list --bogus
check dfn-help 0 'list' -- "$cdff" dfn --help
check dfn-info-help 0 'NAME' -- "$cdff" dfn info --help
check dfn-info-missing-arg 2 'NAME' -- "$cdff" dfn info
check dfn-info-unknown 1 "unknown DFN 'Nope'; expected one of" -- "$cdff" dfn info Nope
check dfn-info 0 'low_threshold +double +default 50' -- "$cdff" dfn info EdgeDetection
check demo-help 0 '--out' -- "$cdff" demo --help
for dfn in ImageUndistortion EdgeDetection FeaturesExtraction2D FeaturesMatching2D \
           StereoRectification EstimationFilter; do
  check "list-$dfn" 0 "^$dfn " -- "$cdff" dfn list
done
check list-one-per-line 0 '^EdgeDetection +edge_detection +Canny Sobel$' -- "$cdff" dfn list
# cdff serve: errors naming the value before it listens (docs/web-ui.md)
check serve-help 0 '--listen' -- "$cdff" serve --help
check serve-missing-recording 2 'File does not exist: nowhere.mcap' -- "$cdff" serve nowhere.mcap
check serve-bad-port 2 '--port' -- "$cdff" serve --port 70000
check serve-bad-listen 1 "listen address 'banana' is not an IP address" -- \
  "$cdff" serve --listen banana --port 0
check serve-no-app 1 "the web application is not in '/nonexistent' \\(no index.html\\)" -- \
  "$cdff" serve --app-dir /nonexistent --port 0
app=$(mktemp -d)
echo '<!doctype html>' > "$app/index.html"
check serve-not-mcap 1 "not an MCAP file" -- "$cdff" serve "$0" --port 0 --app-dir "$app"
rm -r "$app"
# The area column starts at the same offset on every line, however long the longest name.
area_columns=$("$cdff" dfn list | awk '{ print index($0, " " $2 " ") }' | sort -u | wc -l)
if [ "$area_columns" -eq 1 ]; then
  echo "ok   list-columns-aligned"
else
  echo "FAIL list-columns-aligned: the area column starts at $area_columns different offsets"
  failures=$((failures + 1))
fi
echo "$failures failed"
[ "$failures" -eq 0 ]
