#!/usr/bin/env bash
# make demo: first the rendezvous from 2 km to capture (dfpcs/rendezvous.yaml: far-range
# tracking, the LIDAR's position of the target, LIDAR and visual tracking handing the target over
# by range and track state, with no ground truth and no initial state; evaluated per phase);
# then simulate the mid-range approach -> LIDAR tracking DFPC -> evaluation against the
# ground truth (a short table on the terminal and an HTML report); then the same for visual
# tracking on the simulated close-range approach, first from a perturbed truth, then started by
# the detection DFPC with no truth at all.
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

echo "== 0. the rendezvous, 2 km -> capture (docs/rendezvous.md)"
# The sensors the run set reads: the far camera, radar, AHRS and IMU, the LIDAR, and the left
# camera at 2 Hz (the right camera and the ToF camera off: they take most of the simulation's
# time and no graph of the run set reads them). About 1 min to simulate, 35 s to run.
"$cdff" sim rendezvous -o "$out/rdv_sim.mcap" -q --set sensors.camera_right.enabled=false \
  --set sensors.tof.enabled=false --set sensors.camera_left.rate=2
"$cdff" run dfpcs/rendezvous.yaml -i "$out/rdv_sim.mcap" -o "$out/rdv_out.mcap"
# Per phase (far, mid, close range), the hand-overs and each product's continuity; no --check:
# the whole run's verdicts include what does not hold yet (docs/rendezvous.md).
"$cdff" eval "$out/rdv_out.mcap" --camera /chaser/camera/far/calibration \
  --product /cdff/far_range_tracking/bearing --product /cdff/target_state/state \
  --product /cdff/lidar_position/state --json "$out/rdv_report.json" --html "$out/rdv_report.html"
echo "report: $out/rdv_report.html"
echo "== 1. simulate the mid-range approach (17 m -> 2 m, VLP-16 LIDAR with ground truth)"
# Cameras and ToF off: the LIDAR chain needs none of them, and they take most of the time.
"$cdff" sim mid_range_approach -o "$out/sim.mcap" -q \
  --set sensors.camera_left.enabled=false --set sensors.camera_right.enabled=false \
  --set sensors.tof.enabled=false
echo "== 2. initial state: the truth with a Gaussian error of RMS 10 % of the range and 10 degrees"
"$cdff" initial-state "$out/sim.mcap" -o "$out/initial_state.mcap" \
  --position-fraction 0.10 --angle-deg 10 --seed 7
echo "== 3. LIDAR tracking (dfpcs/lidar_tracking.yaml)"
"$cdff" run dfpcs/lidar_tracking.yaml -i "$out/sim.mcap" -i "$out/initial_state.mcap" \
  -o "$out/out.mcap"
echo "== 4. evaluation against the ground truth (exit status 1 if a requirement fails)"
"$cdff" eval --check "$out/out.mcap" --json "$out/report.json" --html "$out/report.html"
echo "report: $out/report.html"
echo "== 5. visual tracking (dfpcs/visual_tracking.yaml) on the simulated close-range approach"
# The left camera only (1624x1234), at 2 Hz to keep the demo short; the DFPC starts from the
# truth with a Gaussian error of RMS 5 % of the range and 5 degrees (a still target: small twist
# sigmas) and its pose
# product, the target in the servicer frame, is evaluated against /truth/target_pose. The graph's
# model file is relative to the repository root, where `make demo` runs.
"$cdff" sim close_range_approach -o "$out/vt_sim.mcap" -q --set sensors.camera_left.rate=2 \
  --set sensors.camera_right.enabled=false --set sensors.lidar.enabled=false \
  --set sensors.tof.enabled=false --set sensors.imu.enabled=false
"$cdff" initial-state "$out/vt_sim.mcap" -o "$out/vt_initial_pose.mcap" \
  --truth /truth/camera_left/target_pose --at /chaser/camera/left/image \
  --channel /cdff/visual_tracking/initial_pose --position-fraction 0.05 --angle-deg 5 \
  --velocity-sigma 0.05 --angular-velocity-sigma-deg 5 --seed 3
"$cdff" run dfpcs/visual_tracking.yaml -i "$out/vt_sim.mcap" -i "$out/vt_initial_pose.mcap" \
  -o "$out/vt_out.mcap"
"$cdff" eval --check "$out/vt_out.mcap" --product /cdff/visual_tracking/pose \
  --json "$out/vt_report.json" --html "$out/vt_report.html"
echo "== 6. detect, then track, with no initial state: the close-range approach, stereo at 5 Hz"
# The detection DFPC (dfpcs/detection.yaml, LINEMOD templates from `make templates`) runs on the
# stereo pairs made from the two cameras' channels (--pair) while the visual tracker is
# UNINITIALISED or LOST (--run-while) and stops while it tracks; its camera-frame state is the
# tracker's initial pose (--map). No ground truth enters the run.
"$cdff" sim close_range_approach -o "$out/dt_sim.mcap" -q --set sensors.camera_left.rate=5 \
  --set sensors.camera_right.rate=5 --set sensors.lidar.enabled=false \
  --set sensors.tof.enabled=false --set sensors.imu.enabled=false
"$cdff" run dfpcs/detection.yaml dfpcs/visual_tracking.yaml -i "$out/dt_sim.mcap" \
  -o "$out/dt_out.mcap" --set detect.template_file="$build/templates/target_stereo.yml.gz" \
  --pair /chaser/stereo/pair=/chaser/camera/left/image,/chaser/camera/right/image \
  --map visual_tracking.initial_pose=/cdff/detection/camera_state \
  --run-while detection=visual_tracking:UNINITIALISED,LOST
"$cdff" eval --check "$out/dt_out.mcap" --product /cdff/visual_tracking/pose \
  --product /cdff/detection/pose --json "$out/dt_report.json" --html "$out/dt_report.html"
echo "reports: $out/rdv_report.html (rendezvous), $out/report.html (LIDAR), $out/vt_report.html (visual)," \
  "$out/dt_report.html (detect, then track)"
# Ours and ViSP's tracker side by side on the same approach (ViSP takes seconds per frame):
#   build/examples/visual_tracking_demo --scenario close_range_approach --rate 2 --dfi both
