#!/usr/bin/env bash
# `cdff train`: templates of a scenario's target and of a mesh file (for a camera, and for a ToF
# camera, whose templates are matched on the depth alone), their check on untrained
# views, and errors naming the value for bad requests. Coarse steps keep it a few seconds.
# usage: train_test.sh CDFF WORK_DIR
set -u
cdff=$1
work=$2
rm -rf "$work"
mkdir -p "$work"

source "$(dirname "${BASH_SOURCE[0]}")/check.sh"

check train-scenario 0 'check on 5 untrained views with depth: detected [0-9]+' -- \
  "$cdff" train mid_range_approach -o "$work/target.yml.gz" --view-step 60 --in-plane-step 90 \
  --ranges 8 --check 5
check train-refined 0 'after PoseRefinement/DepthIcp on the depth: within 2 deg and 1 % of the range [0-9]+' -- \
  "$cdff" train mid_range_approach -o "$work/target.yml.gz" --view-step 60 --in-plane-step 90 \
  --ranges 8 --check 3 --check-seed 7
if [ ! -s "$work/target.yml.gz" ]; then
  echo "FAIL train-file: $work/target.yml.gz missing"; failures=$((failures + 1))
fi
# The same model from its exported mesh has the same hash.
"$cdff" model perturb mid_range_approach -o "$work/model" --points 100 >/dev/null 2>&1
hash=$(zcat "$work/target.yml.gz" | grep -oE 'mesh_hash: "?[0-9a-f]{16}' | grep -oE '[0-9a-f]{16}$')
check train-mesh 0 "mesh hash $hash" -- \
  "$cdff" train "$work/model/target.ply" -o "$work/mesh.yml.gz" --view-step 60 \
  --in-plane-step 90 --ranges 8 --check 0
check train-rectified 0 'fx [0-9.]+ cx [0-9.]+ cy [0-9.]+ \(rectified with camera_right\)' -- \
  "$cdff" train mid_range_approach -o "$work/rectified.yml.gz" --view-step 60 \
  --in-plane-step 90 --ranges 8 --check 0 --rectified-with camera_right
check unknown-partner 1 "has no camera 'camera_middle'; expected --rectified-with" -- \
  "$cdff" train mid_range_approach -o "$work/rectified.yml.gz" --view-step 60 \
  --in-plane-step 90 --ranges 8 --check 0 --rectified-with camera_middle
check missing-model 1 "nonexistent.ply" -- \
  "$cdff" train "$work/nonexistent.ply" -o "$work/x.yml.gz"
check train-tof 0 'camera 320x240 fx [0-9.]+ cx [0-9.]+ cy [0-9.]+ \(a ToF camera: matched on its depth alone\)' -- \
  "$cdff" train mid_range_approach -o "$work/tof.yml.gz" --sensor tof --view-step 60 \
  --in-plane-step 90 --ranges 6 --check 5
check unknown-sensor 1 "has no camera or ToF camera 'camera_middle'" -- \
  "$cdff" train mid_range_approach -o "$work/x.yml.gz" --sensor camera_middle
check negative-range 2 "ranges" -- \
  "$cdff" train mid_range_approach -o "$work/x.yml.gz" --ranges 8,-2
check bad-step 2 "view-step" -- \
  "$cdff" train mid_range_approach -o "$work/x.yml.gz" --view-step 0
# The output's folder is made; one that cannot be (a file is in the way) fails before training.
check new-folder 0 "wrote $work/new/folder/t.yml.gz" -- \
  "$cdff" train mid_range_approach -o "$work/new/folder/t.yml.gz" --view-step 60 \
  --in-plane-step 90 --ranges 8 --check 0
touch "$work/a_file"
check unwritable 1 "cannot create the folder '$work/a_file/dir' of --output" -- \
  "$cdff" train mid_range_approach -o "$work/a_file/dir/t.yml.gz" --view-step 60 \
  --in-plane-step 90 --ranges 8 --check 0

if [ "$failures" -ne 0 ]; then
  echo "$failures failure(s)"
  exit 1
fi
echo "all passed"
