#!/usr/bin/env bash
# `cdff model info | perturb`: a model's parts and sizes, model errors written in every format
# the DFPCs load, and errors naming the value for bad requests; `cdff sim` with the second
# target and with calibration errors.
# usage: model_test.sh CDFF WORK_DIR
set -u
cdff=$1
work=$2
rm -rf "$work"
mkdir -p "$work"

source "$(dirname "${BASH_SOURCE[0]}")/check.sh"

check info-parts 0 'antenna +792 triangles' -- "$cdff" model info mid_range_approach
check info-second-target 0 "model 'hexagonal_satellite'.*" -- \
  "$cdff" model info mid_range_approach --set target.procedural.kind=hexagonal
check perturb 0 'wrote .*/wrong/target.cao' -- "$cdff" model perturb mid_range_approach \
  -o "$work/wrong" --scale-error 0.01 --remove-part antenna --add-box payload=0.3,0,0.6,0.1,0.1,0.1 \
  --retriangulate --max-edge 0.2 --points 1000
for f in target.ply target.cao target_edges.txt target_points.ply target.obj; do
  if [ ! -s "$work/wrong/$f" ]; then
    echo "FAIL perturb-files: $work/wrong/$f missing"; failures=$((failures + 1))
  fi
done
# The perturbed PLY keeps its parts: the payload is there, the antenna is not.
check perturbed-parts 0 'payload' -- "$cdff" model info "$work/wrong/target.ply"
check perturbed-no-antenna 1 "no part 'antenna'" -- \
  "$cdff" model perturb "$work/wrong/target.ply" -o "$work/again" --remove-part antenna

check unknown-part 1 "no part 'dish'; expected one of: bus, " -- \
  "$cdff" model perturb mid_range_approach -o "$work/x" --remove-part dish
check nan-scale 1 "'nan' is not a finite number" -- \
  "$cdff" model perturb mid_range_approach -o "$work/x" --scale-error nan
check negative-box 1 "half extent along y = -0.1 is invalid" -- \
  "$cdff" model perturb mid_range_approach -o "$work/x" --add-box b=0,0,1,0.1,-0.1,0.1
check negative-edge 1 'max_edge = -1 is invalid' -- \
  "$cdff" model perturb mid_range_approach -o "$work/x" --max-edge -1
check missing-output 2 'output' -- "$cdff" model perturb mid_range_approach

check sim-second-target 0 'hexagonal_satellite' -- "$cdff" sim tumbling_target --check \
  --set target.procedural.kind=hexagonal
check sim-calibration-error 0 'calibration error \(gaussian\): extrinsics 0.2 deg, 0.002 m' -- "$cdff" sim mid_range_approach --check \
  --set calibration_error.extrinsic_angle_deg=0.2 --set calibration_error.extrinsic_position=0.002
check sim-negative-calibration-error 1 'calibration_error.extrinsic_position = -0.002' -- \
  "$cdff" sim mid_range_approach --check --set calibration_error.extrinsic_position=-0.002

if [ "$failures" -ne 0 ]; then
  echo "$failures failure(s)"
  exit 1
fi
echo "all passed"
