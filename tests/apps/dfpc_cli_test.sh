#!/usr/bin/env bash
# `cdff dfpc check` and `cdff dfpc graph`: exit statuses and file:line messages.
set -u
cdff=$1
root=$2
graphs=$root/tests/dfpc/graphs
source "$(dirname "${BASH_SOURCE[0]}")/check.sh"
check dfpc-help 0 'check' -- "$cdff" dfpc --help
check dfpc-no-subcommand 2 'subcommand' -- "$cdff" dfpc
check dfpc-unknown-subcommand 2 "unknown subcommand 'chek'.*expected one of \\{check, graph\\}" -- "$cdff" dfpc chek
check dfpc-check-missing-arg 2 'GRAPH' -- "$cdff" dfpc check
check dfpc-graph-missing-arg 2 'GRAPH' -- "$cdff" dfpc graph
check check-pose-filtering 0 "pose_filtering.yaml: ok: DFPC 'pose_filtering', 1 instances" -- \
  "$cdff" dfpc check "$root/dfpcs/pose_filtering.yaml"
check check-unknown-dfn 1 "unknown_dfn.yaml:6:14: instance 'ekf': unknown DFN 'EstimationFiltre'" -- \
  "$cdff" dfpc check "$graphs/unknown_dfn.yaml"
check check-type-mismatch 1 "type_mismatch.yaml:9:5: type mismatch: 'ekf.innovation_nis' is Double but 'state' is RigidBodyState" -- \
  "$cdff" dfpc check "$graphs/type_mismatch.yaml"
check check-cycle 1 "cycle.yaml:11:5: cycle without a delay: first -> second -> first" -- \
  "$cdff" dfpc check "$graphs/cycle.yaml"
check check-parameter 1 "bad_parameter.yaml:9:34: instance 'ekf' \\(EstimationFilter/ExtendedKalman\\): .*position_sigma = -1: out of range; expected a number >= 1e-09 m" -- \
  "$cdff" dfpc check "$graphs/bad_parameter.yaml"
check check-missing-file 1 "nowhere.yaml: cannot open DFPC graph file" -- "$cdff" dfpc check "$graphs/nowhere.yaml"
check check-several 1 "unknown_dfn.yaml:6:14" -- "$cdff" dfpc check "$root/dfpcs/pose_filtering.yaml" "$graphs/unknown_dfn.yaml"
check graph-dot 0 '^digraph "pose_filtering"' -- "$cdff" dfpc graph "$root/dfpcs/pose_filtering.yaml"
check graph-dot-edge 0 '"in:pose" -> "ekf"' -- "$cdff" dfpc graph "$root/dfpcs/pose_filtering.yaml"
check graph-missing-file 1 "cannot open DFPC graph file" -- "$cdff" dfpc graph "$graphs/nowhere.yaml"
echo "$failures failed"
[ "$failures" -eq 0 ]
