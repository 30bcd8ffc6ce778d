"""The external API (seed §7.3) from Python: live measurements pushed into the pose filtering
DFPC, a pose subscription whose callback runs with the GIL on the API's thread (and may call the
API, or cancel itself), queries in a named frame, and errors for requests the state refuses."""
import os
import pathlib
import threading

import numpy as np
import pytest

import cdff

SOURCE = pathlib.Path(os.environ.get("CDFF_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
GRAPH = str(SOURCE / "dfpcs/pose_filtering.yaml")
SIGMA = 0.03  # m, the simulated measurement noise


def measurement(rng, t):
    """camera_T_target at t s: drifting at [0.02, 0, -0.05] m/s, with noise."""
    truth = np.array([0.2 + 0.02 * t, -0.1, 8.0 - 0.05 * t])
    pose = cdff.Transform(truth + SIGMA * rng.normal(size=3), [0, 0, 0, 1], "camera", "target",
                          stamp=int(round(t * 1e6)))
    return cdff.PoseWithCovariance(pose, np.diag([SIGMA ** 2] * 3 + [np.radians(0.5) ** 2] * 3)), truth


def test_live_input_subscription_and_queries():
    servicer_T_camera = cdff.Transform([0.5, 0, 0], [0, 0, 0, 1], "servicer", "camera")
    rng = np.random.default_rng(5)
    with cdff.dfpc.Cdff([GRAPH], static_transforms=[servicer_T_camera]) as api:
        assert api.getCDFFState() == "uninitialised"
        api.setCDFFState("initialize")
        received = []
        statuses = []
        done = threading.Event()

        def on_pose(now, pose):
            received.append(pose)
            # the API may be called from its own callback thread
            statuses.append(api.getDFPCStatus("pose_filtering")["state"])
            if len(received) >= 3:
                done.set()

        sub = api.getDFPCPose("pose_filtering", 50.0, on_pose)
        for k in range(31):
            z, truth = measurement(rng, 0.1 * k)
            api.push("/chaser/target_pose_measurement", z)
        api.flush(10.0)
        assert done.wait(10.0), "the subscription's callback was not called"
        api.cancelSubscription(sub)
        assert all(isinstance(p, (cdff.PoseWithCovariance, cdff.Error)) for p in received)
        assert set(statuses) == {"running"}

        pose = api.getTargetRelativePose("camera")
        error = np.linalg.norm(pose.pose.translation - truth)
        sigma = np.sqrt(np.trace(pose.covariance[:3, :3]))
        assert error < 3 * sigma + 1e-3 and sigma < SIGMA  # filtered: better than one measurement
        in_servicer = api.getTargetRelativePose("servicer")
        np.testing.assert_allclose(in_servicer.pose.translation, pose.pose.translation + [0.5, 0, 0],
                                   atol=1e-9)
        velocity = api.getTargetRelativeVelocity("camera")
        np.testing.assert_allclose(velocity["linear"], [0.02, 0, -0.05], atol=0.05)
        status = api.getDFPCStatus("pose_filtering")
        assert status["messages"] == 31 and status["products"] > 0
        assert "pose_filtering/state" in api.product_names()
        stamp, state = api.product("pose_filtering/state")
        assert isinstance(state, cdff.RigidBodyState) and stamp == 3_000_000

        with pytest.raises(cdff.InvalidInputError, match="initialize"):
            api.setCDFFState("initialize")  # already running
        with pytest.raises(cdff.InvalidInputError, match="not a state request"):
            api.setCDFFState("start")
        with pytest.raises(cdff.InvalidInputError, match="no stamp of its own"):
            api.push("/chaser/target_pose_measurement", 3.0)
        with pytest.raises(cdff.NotFoundError):
            api.getDFPCStatus("no_such_dfpc")
        api.setCDFFState("stop")
    with pytest.raises(cdff.InvalidInputError, match="closed"):
        api.getCDFFState()


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_callback_that_cancels_itself_and_raises():
    with cdff.dfpc.Cdff([GRAPH]) as api:
        api.setCDFFState("initialize")
        calls = []
        done = threading.Event()
        sub = None

        def on_status(now, status):
            calls.append(now)
            api.cancelSubscription(sub)  # from inside its own callback: no deadlock
            done.set()
            raise RuntimeError("a failing callback is reported, never stops the API")

        sub = api.getDFPCStatus("pose_filtering", 100.0, on_status)
        assert done.wait(10.0)
        api.flush(5.0)
        assert len(calls) == 1
        assert api.getCDFFState() == "running"


def test_graph_errors_name_file_and_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(open(GRAPH).read().replace("dfi: ExtendedKalman", "dfi: ExtendedKalmann"))
    with pytest.raises(cdff.Error, match=r"bad.yaml:\d+:\d+: .*ExtendedKalmann"):
        cdff.dfpc.Cdff([str(bad)])
