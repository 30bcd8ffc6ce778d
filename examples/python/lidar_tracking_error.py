#!/usr/bin/env python3
"""Simulate an approach, track it with the LIDAR DFPC and plot the error against the truth.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/lidar_tracking_error.py \
        [--duration 90] [--seed 7] [--out lidar_tracking_error.png]

The simulator runs the mid-range approach (LIDAR only: the cameras are not needed here), the
LIDAR tracking DFPC runs over the recording with no initial state (it acquires the target by
itself), and the estimated pose is compared with the recorded ground truth at each product:
position error against the requirement SR_DFPC_0100 (< 1 m at mid range) and as a fraction of
the range, attitude error against its < 10 deg. The summary printed is cdff.eval's.
"""
import argparse
import pathlib
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")  # files only: no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import cdff  # noqa: E402

SOURCE = pathlib.Path(__file__).resolve().parents[2]
LIDAR_ONLY = {f"sensors.{s}.enabled": False for s in ("camera_left", "camera_right", "tof", "imu")}


def series(path, channel):
    """(stamps in s, values) of one channel."""
    messages = list(cdff.io.read(path, channels=[channel]))
    return np.array([m.stamp * 1e-6 for m in messages]), [m.value for m in messages]


def errors(run):
    t, states = series(run, "/cdff/lidar_tracking/pose")
    truth_t, truth = series(run, "/truth/target_pose")
    track_t, track = series(run, "/cdff/lidar_tracking/track_state")
    position, angle, rng, tracked = [], [], [], []
    for stamp, state in zip(t, states):
        k = int(np.argmin(np.abs(truth_t - stamp)))  # truth at 20 Hz: the nearest sample
        true_pose = truth[k].pose
        position.append(np.linalg.norm(state.pose.translation - true_pose.translation))
        angle.append(np.degrees(cdff.angular_distance(state.pose.quaternion_xyzw,
                                                      true_pose.quaternion_xyzw)))
        rng.append(np.linalg.norm(true_pose.translation))
        j = np.searchsorted(track_t, stamp, side="right") - 1
        tracked.append(j >= 0 and track[j].is_tracked())
    return t, np.array(position), np.array(angle), np.array(rng), np.array(tracked, bool)


def plot(t, position, angle, rng, tracked, out, title):
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for ax, y, label, limit in ((axes[0], position, "position error (m)", 1.0),
                                (axes[1], 100 * position / rng, "position error (% of range)", None),
                                (axes[2], angle, "attitude error (deg)", 10.0)):
        ax.semilogy(t[tracked], y[tracked], ".", ms=3, label="TRACKING / DEGRADED")
        ax.semilogy(t[~tracked], y[~tracked], "x", ms=3, color="0.6", label="not tracked")
        if limit:
            ax.axhline(limit, color="r", lw=1, label="SR_DFPC_0100 bound")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=90)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=90.0, help="simulated seconds")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--out", default="lidar_tracking_error.png")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as work:
        sim = pathlib.Path(work) / "sim.mcap"
        run = pathlib.Path(work) / "run.mcap"
        info = cdff.sim.run("mid_range_approach", sim, seed=args.seed, duration=args.duration,
                            overrides=LIDAR_ONLY)
        result = cdff.dfpc.run([SOURCE / "dfpcs/lidar_tracking.yaml"], [sim], run,
                               settings=[f"model.mesh_file={SOURCE / 'data/models/target.ply'}"])
        report = cdff.eval.evaluate(run, products=["/cdff/lidar_tracking/pose"])
        t, position, angle, rng, tracked = errors(run)
    pose = report["products"][0]
    summary = (f"{info['scenario']}, seed {info['seed']}, {info['duration']:.0f} s, "
               f"{pose['frames']} poses ({result['summary']['products']} products in all)\n"
               f"tracked {pose['tracked_fraction']:.0%}; "
               f"p95 {pose['position_error_pct_range']['p95']:.3f} % of range, "
               f"{pose['angle_error_deg']['p95']:.2f} deg (cdff.eval)")
    print(summary)
    if not tracked.any():
        print("error: the DFPC never tracked the target", file=sys.stderr)
        return 1
    plot(t, position, angle, rng, tracked, args.out, "LIDAR tracking from Python, " + summary)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
