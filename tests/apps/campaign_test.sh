#!/usr/bin/env bash
# `cdff campaign` and `cdff campaign-report`: a small campaign run by the local pool (two jobs),
# its report (pass fractions with intervals, the runs that produced no pose), resumption (runs
# done are not redone; a missing result is redone alone), and errors for bad campaigns and for a
# results folder of another campaign.
# usage: campaign_test.sh CDFF SOURCE_DIR WORK_DIR
set -u
cdff=$1
source_dir=$2
work=$3
rm -rf "$work"
mkdir -p "$work"
cd "$source_dir" || exit 1  # the graphs' model paths are relative to the source tree

source "$(dirname "${BASH_SOURCE[0]}")/check.sh"

# 4 runs of 3 s of the smoke campaign's LIDAR-only approach, two dispersions.
sed -e 's/^runs: 20/runs: 4/' -e 's/duration: 20/duration: 3/' \
  data/campaigns/lidar_tracking_smoke.yaml > "$work/small.yaml"
out="$work/results"

check campaign-check 0 'ok \(4 runs, 1 scenarios, 9 dispersions, 1 graphs\)' -- \
  "$cdff" campaign "$work/small.yaml" --check
check campaign-run 0 'campaign lidar_tracking_smoke: 4 of 4 runs done' -- \
  "$cdff" campaign "$work/small.yaml" -o "$out" -j 2
check campaign-results 0 '"status": "(ok|no_product)"' -- cat "$out/runs/000003/result.json"
check campaign-report-interval 0 '"pass_interval"' -- cat "$out/report.json"
check campaign-reproduce 0 'cdff sim mid_range_approach -o sim.mcap --seed 1000004 --duration 3' -- \
  cat "$out/runs/000003/result.json"
check campaign-resume 0 '0 runs done now \(0 failed, 0 retried\), 4 done before' -- \
  "$cdff" campaign "$work/small.yaml" -o "$out" -j 2
rm "$out/runs/000002/result.json"
check campaign-redo-one 0 '1 runs done now \(0 failed, 0 retried\), 3 done before' -- \
  "$cdff" campaign "$work/small.yaml" -o "$out" -j 2
check campaign-report 0 'SR_DFPC_0100 /cdff/lidar_tracking/pose position_error_m < 1.0: pass [0-9]+/4' -- \
  "$cdff" campaign-report "$out"

# a tracker started from a perturbed truth (the initial-state stage)
cp "$work/small.yaml" "$work/init.yaml"
echo "    initial_state: {channel: /cdff/lidar_tracking/initial_state, position_fraction: 0.05, angle_deg: 5}" \
  >> "$work/init.yaml"
check campaign-initial-state 0 '4 of 4 runs done: 4 evaluated' -- \
  "$cdff" campaign "$work/init.yaml" -o "$work/init" -j 2
check campaign-initial-state-reproduce 0 'cdff initial-state sim.mcap -o init0.mcap --channel /cdff/lidar_tracking/initial_state .*-i sim.mcap -i init0.mcap' -- \
  cat "$work/init/runs/000001/result.json"
sed 's/angle_deg: 5}/angle_deg: 500}/' "$work/init.yaml" > "$work/init_bad.yaml"
check campaign-initial-state-range 1 'init_bad.yaml:[0-9]+:[0-9]+: dfpcs.0.initial_state.angle_deg = 500: out of range' -- \
  "$cdff" campaign "$work/init_bad.yaml" -o "$work/init_bad"

# a tracker whose every frame faults publishes only invalid estimates: the run counts as one
# without a pose (not as evaluated with no requirement applying), and its result says why (the
# visual tracker started from a servicer-frame state where the graph expects a camera-frame one)
cat > "$work/invalid.yaml" <<'YAML'
name: invalid_estimates
runs: 1
scenarios:
  - name: close_range_approach
    duration: 2
    set: {sensors.camera_left.rate: 2, sensors.camera_right.enabled: false, sensors.lidar.enabled: false,
          sensors.tof.enabled: false, sensors.imu.enabled: false}
dfpcs:
  - graph: dfpcs/visual_tracking.yaml
    initial_state: {channel: /cdff/visual_tracking/initial_pose, at: /chaser/camera/left/image}
YAML
check campaign-invalid-estimates 0 '1 of 1 runs done: 0 evaluated, 1 without a pose product' -- \
  "$cdff" campaign "$work/invalid.yaml" -o "$work/invalid"
check campaign-invalid-estimates-why 0 '"last_fault": "error at t = [0-9]+ us in to_servicer: .*expected a pose in frame .camera_left_optical.' -- \
  cat "$work/invalid/runs/000000/result.json"
check campaign-scenario-summary 0 'scenario close_range_approach: 1 runs, 0 evaluated \(0 meeting every requirement that applied\), 1 without a pose, 0 failed, 1 with DFPC faults' -- \
  "$cdff" campaign-report "$work/invalid"

# errors
sed 's/^runs: 4/runs: 5/' "$work/small.yaml" > "$work/other.yaml"
check campaign-other-folder 1 "holds the results of campaign 'lidar_tracking_smoke' \(.*small.yaml\)" -- \
  "$cdff" campaign "$work/other.yaml" -o "$out"
sed 's/sensors.lidar.range_noise/sensors.lidar.range_nois/' "$work/small.yaml" > "$work/typo.yaml"
check campaign-unknown-key 1 "typo.yaml:[0-9]+:[0-9]+: dispersion 'sensors.lidar.range_nois'.*did you mean 'range_noise'" -- \
  "$cdff" campaign "$work/typo.yaml" -o "$work/typo"
sed 's/^runs: 4/runs: -4/' "$work/small.yaml" > "$work/negative.yaml"
check campaign-negative-runs 1 'negative.yaml:[0-9]+:[0-9]+: runs = -4: out of range; expected an integer in \[1, 1000000\]' -- \
  "$cdff" campaign "$work/negative.yaml" -o "$work/negative"
check campaign-missing 1 'cannot open campaign' -- "$cdff" campaign "$work/none.yaml" -o "$work/none"
check campaign-report-not-results 1 'is not a campaign.s results folder' -- \
  "$cdff" campaign-report "$work"
check campaign-no-output 2 'expected -o DIR' -- "$cdff" campaign "$work/small.yaml"

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
