"""Recordings, the simulator and the evaluation from Python: a simulated approach, tracked by the
LIDAR DFPC and evaluated, gives the figures `cdff eval --json` gives; recordings written from
Python read back equal; a truncated recording yields what precedes the damage, then an error."""
import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import cdff

SOURCE = pathlib.Path(os.environ.get("CDFF_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
BUILD = pathlib.Path(os.environ.get("CDFF_BUILD_DIR", SOURCE / "build"))
# LIDAR only (the cameras' rendering is what a simulation spends most on)
LIDAR_ONLY = {f"sensors.{s}.enabled": False
              for s in ("camera_left", "camera_right", "tof", "imu")}


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "sim.mcap"
    info = cdff.sim.run("mid_range_approach", out, seed=11, duration=3.0, overrides=LIDAR_ONLY)
    assert info["seed"] == 11 and info["duration"] == 3.0
    return out


def test_simulation_holds_truth_and_scans(simulated):
    channels = {c["channel"]: c for c in cdff.io.channels(simulated)}
    assert channels["/truth/target_pose"]["type"] == "PoseWithCovariance"
    assert channels["/chaser/lidar/points"]["type"] == "PointCloud"
    assert "/chaser/camera_left/image" not in channels  # the override took
    scans = [m.value for m in cdff.io.read(simulated, channels=["/chaser/lidar/points"])]
    assert len(scans) == channels["/chaser/lidar/points"]["message_count"] >= 25
    assert all(isinstance(s, cdff.PointCloud) and len(s) > 20 for s in scans)
    # the target is about 17 m away at the start of this approach
    ranges = np.linalg.norm(scans[0].points, axis=1)
    assert 10 < np.median(ranges) < 25


def test_lidar_tracking_evaluated_as_the_command_does(simulated, tmp_path):
    run = tmp_path / "run.mcap"
    result = cdff.dfpc.run([SOURCE / "dfpcs/lidar_tracking.yaml"], [simulated], run,
                           settings=[f"model.mesh_file={SOURCE / 'data/models/target.ply'}"])
    assert result["summary"]["products"] > 0
    status = result["dfpcs"][0]
    # (faults are not asserted: a call over its time budget on a loaded machine is one)
    assert status["name"] == "lidar_tracking" and status["messages"] > 0 and status["products"] > 0
    report = cdff.eval.evaluate(run)
    cli_json = tmp_path / "report.json"
    subprocess.run([BUILD / "apps/cdff", "eval", run, "--json", cli_json, "-q"], check=True)
    expected = json.loads(cli_json.read_text())
    report.pop("notes")
    assert report == expected
    pose = next(p for p in report["products"] if p["channel"] == "/cdff/lidar_tracking/pose")
    # the LIDAR tracker's requirement at mid range (docs/lidar-tracking.md): 1 % of range, 1 deg
    assert pose["position_error_pct_range"]["p95"] < 1.0
    assert pose["angle_error_deg"]["p95"] < 1.0


def test_written_values_read_back_equal(tmp_path):
    path = tmp_path / "values.mcap"
    image = cdff.Image(np.arange(12 * 16, dtype=np.uint8).reshape(12, 16), stamp=5, frame_id="cam")
    cloud = cdff.PointCloud(np.random.default_rng(0).normal(size=(50, 4)).astype(np.float32),
                            stamp=7, frame_id="lidar")
    pose = cdff.PoseWithCovariance(cdff.Transform([1, 2, 3], [0, 0, 0, 1], "a", "b", 9),
                                   np.eye(6) * 1e-4)
    with cdff.io.Writer(path) as w:
        w.write("/image", image)
        w.write("/cloud", cloud)
        w.write("/pose", pose)
        w.write("/count", 3, stamp=11)
        w.write("/record", {"a": [1, 2]}, stamp=12)
        with pytest.raises(TypeError, match="none of the CDFF data types"):
            w.write("/bad", object(), stamp=1)
    read = {m.channel: m for m in cdff.io.read(path)}
    np.testing.assert_array_equal(read["/image"].value.array, image.array)
    assert read["/image"].stamp == 5 and read["/image"].value.frame_id == "cam"
    np.testing.assert_array_equal(read["/cloud"].value.points, cloud.points)
    np.testing.assert_array_equal(read["/pose"].value.covariance, pose.covariance)
    assert read["/count"].value == 3 and read["/count"].type == "Int"
    assert read["/record"].value["a"] == [1, 2]  # the recording adds the record's timestamp


def test_truncated_recording(tmp_path, simulated):
    data = simulated.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 3])
    seen = 0
    with pytest.raises(cdff.CorruptDataError, match="cut.mcap"):
        for _ in cdff.io.read(cut):
            seen += 1
    assert seen > 0  # what precedes the damage is delivered first


def test_default_output_is_named_after_scenario_and_seed(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    info = cdff.sim.run("mid_range_approach", seed=4, duration=0.3, overrides=LIDAR_ONLY)
    assert info["output"] == "mid_range_approach_seed4.mcap"
    assert (tmp_path / "mid_range_approach_seed4.mcap").stat().st_size > 0


def test_run_options_are_checked_before_anything_runs(simulated, tmp_path):
    graph = SOURCE / "dfpcs/lidar_tracking.yaml"
    mesh = f"model.mesh_file={SOURCE / 'data/models/target.ply'}"
    out = tmp_path / "r.mcap"
    with pytest.raises(cdff.Error, match="no_such"):
        cdff.dfpc.run([graph], [simulated], out, settings=[mesh],
                      run_while=["no_such=lidar_tracking:LOST"])
    with pytest.raises(cdff.InvalidParameterError, match="stereo pairing .not a pairing."):
        cdff.dfpc.run([graph], [simulated], out, settings=[mesh], pairs=["not a pairing"])
    with pytest.raises(cdff.Error, match="nosuchnode"):
        cdff.dfpc.run([graph], [simulated], out, settings=[mesh, "nosuchnode.x=1"])


def test_missing_files_and_names(tmp_path):
    with pytest.raises(cdff.IoError, match="nothing.mcap"):
        cdff.io.read(tmp_path / "nothing.mcap")
    with pytest.raises(cdff.NotFoundError, match="no_such_scenario"):
        cdff.sim.run("no_such_scenario", tmp_path / "x.mcap")
    with pytest.raises(cdff.Error, match="sensors.lidar.rate"):
        cdff.sim.run("mid_range_approach", tmp_path / "x.mcap", overrides={"sensors.lidar.rate": -1})
    with pytest.raises(cdff.InvalidParameterError, match="statistic 'median'"):
        cdff.eval.evaluate(tmp_path / "x.mcap", statistic="median")


def test_far_range_bearings_evaluated_as_the_command_does(tmp_path):
    # 40 s of the far-range approach (seed 1: designated automatically at 12 s); the run's
    # recording carries the far camera's calibration, so the bearing's error comes in pixels.
    sim = tmp_path / "far.mcap"
    cdff.sim.run("far_range_approach", sim, seed=1, duration=40.0)
    run = tmp_path / "run.mcap"
    cdff.dfpc.run([SOURCE / "dfpcs/far_range_tracking.yaml"], [sim], run)
    report = cdff.eval.evaluate(run, products=["/cdff/far_range_tracking/bearing"])
    cli_json = tmp_path / "report.json"
    subprocess.run([BUILD / "apps/cdff", "eval", run, "--json", cli_json, "-q",
                    "--product", "/cdff/far_range_tracking/bearing"], check=True)
    report.pop("notes")
    assert report == json.loads(cli_json.read_text())
    (bearing,) = report["bearings"]
    assert bearing["camera_channel"] == "/chaser/camera/far/calibration"
    assert bearing["valid_frames"] > 10
    # 2 km: the tracked point within a few pixels of the centre of mass (docs/far-range-tracking.md)
    assert bearing["bearing_error_px"]["rmse"] < 4.0
    given = cdff.eval.evaluate(run, products=["/cdff/far_range_tracking/bearing"], focal_px=1000.0)
    px = given["bearings"][0]["bearing_error_px"]["max"]
    assert px == pytest.approx(bearing["bearing_error_urad"]["max"] * 1e-3, rel=1e-9)
    with pytest.raises(cdff.InvalidParameterError, match="focal_px = -1"):
        cdff.eval.evaluate(run, focal_px=-1.0)
