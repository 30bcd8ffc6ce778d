#!/usr/bin/env python3
"""The Python binding's costs, measured beside the C++ figures of the same run.

    PYTHONPATH=build/python /usr/bin/python3 bench/python_binding_bench.py --build build \
        [--json out/bench/python_binding.json]

- One DFN call (a pose into FrameTransformation/Rigid, process(), the pose out) from Python and
  from C++ (framework_bench's BM_DfnCallFromCpp and BM_DfnProcessOnlyFromCpp, run by this
  script): the difference is what the binding adds per call.
- Data crossing without a copy: a 1 MP image and a 1 M point cloud into CDFF types and back out
  as NumPy views, against the copying path of each (a strided image, an (N, 3) cloud).
Each Python figure is the best of 7 repeats of a loop long enough to last about 0.2 s.
"""
import argparse
import json
import pathlib
import subprocess
import sys
import time
import warnings

import numpy as np

import cdff


def per_call(fn, min_time=0.2, repeats=7):
    """Seconds per call of fn(): the best of `repeats` loops of n calls, n lasting ~min_time."""
    n = 1
    while True:
        start = time.perf_counter()
        for _ in range(n):
            fn()
        elapsed = time.perf_counter() - start
        if elapsed > min_time / 4:
            break
        n *= 4
    n = max(1, int(n * min_time / max(elapsed, 1e-9)))
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, (time.perf_counter() - start) / n)
    return best


def cpp_figures(build):
    exe = pathlib.Path(build) / "bench" / "framework_bench"
    out = subprocess.run([exe, "--benchmark_filter=BM_Dfn", "--benchmark_format=json",
                          "--benchmark_min_time=0.2", "--benchmark_repetitions=7",
                          "--benchmark_report_aggregates_only=true"],
                         check=True, capture_output=True, text=True).stdout
    figures = {}
    for b in json.loads(out)["benchmarks"]:
        if b.get("aggregate_name") == "median":
            figures[b["run_name"]] = b["real_time"] * {"ns": 1e-9, "us": 1e-6}[b["time_unit"]]
    return figures


def dfn_call_figures():
    node = cdff.dfn.FrameTransformation("Rigid")
    node.inputs.extrinsic = cdff.Transform([0.5, 0, 0], [0, 0, 0, 1], "servicer", "lidar")
    pose = cdff.PoseWithCovariance(cdff.Transform([1, 2, 3], [0, 0, 0, 1], "lidar", "target", 1000),
                                   np.eye(6) * 1e-4)
    inputs, outputs = node.inputs, node.outputs

    def call():
        inputs.pose = pose
        node.process()
        return outputs.pose

    node.inputs.pose = pose
    return {"call": per_call(call), "process": per_call(node.process)}


def data_figures():
    image = np.zeros((1000, 1000), np.uint8)
    strided = np.zeros((1000, 2000), np.uint8)[:, ::2]
    cloud4 = np.zeros((1_000_000, 4), np.float32)
    cloud3 = np.zeros((1_000_000, 3), np.float32)
    wrapped_image = cdff.Image(image)
    wrapped_cloud = cdff.PointCloud(cloud4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cdff.CopyWarning)
        return {
            "image_1mp_in": per_call(lambda: cdff.Image(image)),
            "image_1mp_out": per_call(lambda: wrapped_image.array),
            "image_1mp_in_copied": per_call(lambda: cdff.Image(strided), min_time=0.5),
            "cloud_1m_in": per_call(lambda: cdff.PointCloud(cloud4)),
            "cloud_1m_out": per_call(lambda: wrapped_cloud.points),
            "cloud_1m_in_copied": per_call(lambda: cdff.PointCloud(cloud3), min_time=0.5),
        }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default="build")
    parser.add_argument("--json", help="also write the figures to this file")
    args = parser.parse_args()
    cpp = cpp_figures(args.build)
    py = dfn_call_figures()
    data = data_figures()
    rows = [
        ("DFN call (pose in, process, pose out)", py["call"], cpp["BM_DfnCallFromCpp"]),
        ("DFN process() only", py["process"], cpp["BM_DfnProcessOnlyFromCpp"]),
    ]
    print(f"{'':40} {'Python':>10} {'C++':>10} {'added':>10}")
    for name, p, c in rows:
        print(f"{name:40} {p * 1e6:8.2f} us {c * 1e6:8.2f} us {(p - c) * 1e6:8.2f} us")
    print()
    for name, t in data.items():
        print(f"{name:40} {t * 1e6:10.2f} us")
    figures = {"python_s": py, "cpp_s": cpp, "data_s": data,
               "added_per_call_s": py["call"] - cpp["BM_DfnCallFromCpp"]}
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
