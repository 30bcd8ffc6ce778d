#!/usr/bin/env bash
# make demo: simulate the mid-range approach -> LIDAR tracking DFPC -> evaluation against the
# ground truth (a short table on the terminal and an HTML report); then visual tracking on the
# simulated close-range approach.
#   scripts/demo.sh BUILD_DIR OUT_DIR
# Each step is one `cdff` command, so any of them can be run by hand on other data.
set -euo pipefail
build=${1:-build}
out=${2:-out/demo}
cdff=$build/apps/cdff
mkdir -p "$out"

missing=()
for sub in run eval; do
  "$cdff" "$sub" --help > /dev/null 2>&1 || missing+=("cdff $sub")
done
if ((${#missing[@]})); then
  echo "demo: this build has no ${missing[*]} (the DFPC runner and evaluation commands);" \
       "the LIDAR tracking demo needs them" >&2
  exit 1
fi

echo "== 1. simulate the mid-range approach (17 m -> 2 m, VLP-16 LIDAR with ground truth)"
# Cameras and ToF off: the LIDAR chain needs none of them, and they take most of the time.
"$cdff" sim mid_range_approach -o "$out/sim.mcap" -q \
  --set sensors.camera_left.enabled=false --set sensors.camera_right.enabled=false \
  --set sensors.tof.enabled=false
echo "== 2. initial state: the truth perturbed by 10 % of the range and 10 degrees"
"$cdff" initial-state "$out/sim.mcap" -o "$out/initial_state.mcap" \
  --position-fraction 0.10 --angle-deg 10 --seed 7
echo "== 3. LIDAR tracking (dfpcs/lidar_tracking.yaml)"
"$cdff" run dfpcs/lidar_tracking.yaml -i "$out/sim.mcap" -i "$out/initial_state.mcap" \
  -o "$out/out.mcap"
echo "== 4. evaluation against the ground truth"
"$cdff" eval "$out/out.mcap" --json "$out/report.json" --html "$out/report.html"
echo "report: $out/report.html"
echo "== 5. visual tracking (dfpcs/visual_tracking.yaml) on the simulated close-range approach"
# The simulator renders the 1624x1234 camera in-process and the DFPC tracks it from a pose off
# by 5 % of the range and 5 degrees; errors against the ground truth, one row per chain.
"$build/examples/visual_tracking_demo" --scenario close_range_approach --rate 2 --dfi EdgeTracker
