#!/usr/bin/env bash
# `cdff sim`: the MCAP recording (channels, types, frames), byte-identical files for the same
# seed, different files for another seed, the library listing, the progress report, and errors
# naming file, key and value for bad scenarios and options.
# usage: sim_test.sh CDFF WORK_DIR
set -u
cdff=$1
work=$2
rm -rf "$work"
mkdir -p "$work"

source "$(dirname "${BASH_SOURCE[0]}")/check.sh"

# Small cameras keep the runs short; everything else is the scenario's.
small=()
for camera in camera_left camera_right; do
  small+=(--set "sensors.$camera.width=320" --set "sensors.$camera.height=240"
          --set "sensors.$camera.fx=300" --set "sensors.$camera.fy=300")
done
run() {  # run OUT SEED [more options]
  local out=$1 seed=$2
  shift 2
  "$cdff" sim sensor_faults -o "$out" --seed "$seed" --duration 1.2 "${small[@]}" \
    --set sensors.radar.enabled=true --set faults.7.start=0.2 "$@"
}

check sim-list 0 'mid_range_approach .*' -- "$cdff" sim --list
count=$("$cdff" sim --list | wc -l)
if [ "$count" -lt 6 ]; then
  echo "FAIL sim-list-count: $count scenarios, expected at least the issue's 6"
  failures=$((failures + 1))
fi

# The progress report: a line per 10 % when stderr is not a terminal.
check sim-write 0 'cdff sim: 100%' -- run "$work/a.mcap" 7
check sim-write-again 0 '' -- run "$work/b.mcap" 7 -q
check sim-other-seed 0 '' -- run "$work/c.mcap" 8 -q
if cmp -s "$work/a.mcap" "$work/b.mcap"; then
  echo "ok   sim-same-seed-identical-bytes ($(stat -c %s "$work/a.mcap") bytes)"
else
  echo "FAIL sim-same-seed-identical-bytes: two runs with seed 7 differ"
  cmp "$work/a.mcap" "$work/b.mcap" | head -3
  failures=$((failures + 1))
fi
if cmp -s "$work/a.mcap" "$work/c.mcap"; then
  echo "FAIL sim-other-seed-differs: seeds 7 and 8 wrote the same file"
  failures=$((failures + 1))
else
  echo "ok   sim-other-seed-differs"
fi

# What the recording holds: every sensor and truth channel with the recording library's types.
info=$("$cdff" log info "$work/a.mcap" 2>&1)
for pair in "/chaser/camera/left/image Image" "/chaser/camera/right/image Image" \
            "/chaser/camera/left/calibration CameraModel" "/chaser/lidar/points PointCloud" \
            "/chaser/tof/depth DepthMap" "/chaser/imu ImuSample" "/chaser/radar/range Double" \
            "/chaser/tf/camera_left_optical Transform" "/truth/target_pose PoseWithCovariance" \
            "/truth/target_state RigidBodyState" "/truth/target_twist Json" \
            "/truth/camera_left/target_pose PoseWithCovariance" \
            "/truth/lidar/target_pose PoseWithCovariance" "/truth/tf/servicer Transform" \
            "/truth/target_mesh TriangleMesh" "/truth/faults Json"; do
  set -- $pair
  if grep -qE -- "$1 +${2:-}" <<<"$info"; then
    echo "ok   sim-channel $1 ${2:-}"
  else
    echo "FAIL sim-channel $1 ${2:-}: not in cdff log info:"; echo "$info" | head -60
    failures=$((failures + 1))
  fi
done
# The truth pose pairs with DFPC products: parent servicer, child target.
check sim-truth-parent 0 '"frame_id":"servicer"' -- \
  "$cdff" log cat "$work/a.mcap" --channel /truth/target_pose --limit 1
check sim-truth-child 0 '"cdff_child_frame_id":"target"' -- \
  "$cdff" log cat "$work/a.mcap" --channel /truth/target_pose --limit 1
check sim-lidar-truth-parent 0 '"frame_id":"lidar"' -- \
  "$cdff" log cat "$work/a.mcap" --channel /truth/lidar/target_pose --limit 1
check sim-fault-recorded 0 '"fault":"lidar_dropout"' -- \
  "$cdff" log cat "$work/a.mcap" --channel /truth/faults --limit 1
check sim-file-readable 0 'messages' -- "$cdff" log info "$work/a.mcap" --quick

# Bad input: the file, the key and the value, and a non-zero status.
printf 'name: bad\nduration: 5\nsensors:\n  lidar:\n    range_noise: -1\n' >"$work/bad_value.yaml"
check sim-bad-value 1 "bad_value.yaml.*sensors.lidar.range_noise.*-1" -- \
  "$cdff" sim "$work/bad_value.yaml" --check
printf 'name: bad\nduration: 5\nsensors:\n  camera_left:\n    exposur_time: 0.01\n' \
  >"$work/bad_key.yaml"
check sim-bad-key 1 "bad_key.yaml.*exposur_time.*exposure_time" -- \
  "$cdff" sim "$work/bad_key.yaml" --check
printf 'name: bad\nduration: [5\n' >"$work/bad_yaml.yaml"
check sim-bad-yaml 1 "bad_yaml.yaml" -- "$cdff" sim "$work/bad_yaml.yaml" --check
check sim-bad-set 1 "sensors.lidar.rate.*fast" -- \
  "$cdff" sim mid_range_approach --check --set sensors.lidar.rate=fast
check sim-unknown-scenario 1 "no_such_scenario" -- "$cdff" sim no_such_scenario --check
check sim-no-output 2 "OUT.mcap" -- "$cdff" sim mid_range_approach
check sim-unwritable 1 "/nonexistent_dir/x.mcap" -- \
  "$cdff" sim mid_range_approach -o /nonexistent_dir/x.mcap -q --duration 0.1

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all sim checks passed"
