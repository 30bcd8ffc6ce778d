#!/usr/bin/env bash
# `cdff campaign --slurm` against a real single-node Slurm (munged, slurmctld and slurmd started
# here on localhost, torn down after): a small campaign as an array job of 2 tasks, waited for,
# gives the results and the report the local pool gives; resubmitting redoes nothing; a Slurm
# that cannot be reached is a clear error, and the local pool runs only with --fallback-local.
# usage: campaign_slurm_test.sh CDFF SOURCE_DIR WORK_DIR
set -u
cdff=$1
source_dir=$2
work=$3
rm -rf "$work"
mkdir -p "$work"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
source "$here/check.sh"
source "$here/slurm_cluster.sh"
cd "$source_dir" || exit 1

sed -e 's/^runs: 20/runs: 4/' -e 's/duration: 20/duration: 3/' \
  data/campaigns/lidar_tracking_smoke.yaml > "$work/small.yaml"

# Slurm unreachable: a clear error, and the local pool only when asked
check slurm-unreachable 1 'sbatch could not submit the campaign.s array job .*is Slurm reachable' -- \
  "$cdff" campaign "$work/small.yaml" -o "$work/unreachable" --slurm --sbatch /nonexistent/sbatch
check slurm-fallback 0 'running on this machine \(--fallback-local\)' -- \
  "$cdff" campaign "$work/small.yaml" -o "$work/fallback" --slurm --sbatch /nonexistent/sbatch \
  --fallback-local -j 2
check slurm-fallback-report 0 '4 of 4 runs done' -- "$cdff" campaign-report "$work/fallback"

slurm_start "$work/slurm" || { echo "FAIL slurm-start"; exit 1; }
check slurm-run 0 'Slurm job [0-9]+ \(2 array tasks\) ended' -- \
  "$cdff" campaign "$work/small.yaml" -o "$work/results" --slurm --tasks 2 --wait
check slurm-report 0 '4 of 4 runs done' -- "$cdff" campaign-report "$work/results"
check slurm-task-logs 0 '_1.log' -- ls "$work/results/slurm"
# the same runs as the local pool's: the same draws give the same poses (timings aside)
figures='import json, sys
r = json.load(open(sys.argv[1]))
products = r.get("evaluation", {}).get("products", [])
print(r["status"], r["draw"], r["dispersed"],
      [(p["channel"], p["position_error_m"], p["angle_error_deg"]) for p in products])'
for i in 0 1 2 3; do
  a=$(/usr/bin/python3 -c "$figures" "$work/results/runs/00000$i/result.json")
  b=$(/usr/bin/python3 -c "$figures" "$work/fallback/runs/00000$i/result.json")
  if [ "$a" != "$b" ]; then
    echo "FAIL slurm-same-as-local: run $i differs:"; echo "$a"; echo "$b"; failures=$((failures + 1))
  else
    echo "ok   slurm-same-as-local run $i"
  fi
done
touch "$work/before-resubmit"
check slurm-resubmit 0 'Slurm job [0-9]+ \(2 array tasks\) ended' -- \
  "$cdff" campaign "$work/small.yaml" -o "$work/results" --slurm --tasks 2 --wait
check slurm-nothing-redone 0 '^$' -- find "$work/results/runs" -name result.json -newer "$work/before-resubmit"
slurm_stop

echo "$failures failure(s)"
[ "$failures" -eq 0 ]
