#!/usr/bin/env bash
# The LIDAR tracking smoke campaign (data/campaigns/lidar_tracking_smoke.yaml, 20 runs): every run
# ends with a result, no run fails, and SR_DFPC_0100 passes on the tracker's pose in at least 14
# runs (today 16: 4 dispersed attitudes are never acquired in 20 s; a bound near today's figure).
# usage: campaign_smoke_test.sh CDFF SOURCE_DIR WORK_DIR
set -u
cdff=$1
source_dir=$2
work=$3
rm -rf "$work"
cd "$source_dir" || exit 1
"$cdff" campaign data/campaigns/lidar_tracking_smoke.yaml -o "$work" -j 2 || exit 1
/usr/bin/python3 - "$work/report.json" <<'PY'
import json, sys
report = json.load(open(sys.argv[1]))
runs = report["runs"]
assert runs["done"] == 20 and runs["failed"] == 0, runs
rows = [r for r in report["requirements"]
        if r["id"] == "SR_DFPC_0100" and r["channel"] == "/cdff/lidar_tracking/pose"]
assert len(rows) == 2, rows
for r in rows:
    print(f"{r['quantity']}: pass {r['pass']}/{r['pass'] + r['fail']}, "
          f"interval {r['pass_interval']}, measured {r['measured']}")
    assert r["pass"] >= 14, r
    # the runs with a pose stay well inside the requirement: p95 of the runs' p95 errors
    bound = 0.2 if r["quantity"] == "position_error_m" else 2.0  # 1/5 of 1 m and 10 deg
    assert r["measured"]["p95"] < bound, r
PY
