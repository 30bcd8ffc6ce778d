"""DFPCs from Python: graphs run over recordings (as `cdff run`), and the external API.

    result = cdff.dfpc.run(["dfpcs/lidar_tracking.yaml"], ["sim.mcap"], "run.mcap")
    report = cdff.eval.evaluate("run.mcap")

    with cdff.dfpc.Cdff(["dfpcs/pose_filtering.yaml"]) as api:      # live input
        api.setCDFFState("initialize")
        api.getDFPCPose("pose_filtering", 10.0, lambda now, pose: print(now, pose))
        api.push("/chaser/measured_pose", pose)
        api.flush()
"""
import os

from cdff._core._dfpc import Cdff

__all__ = ["Cdff", "run"]


def _paths(p):
    return [str(p)] if isinstance(p, (str, os.PathLike)) else [str(x) for x in p]


def run(graphs, inputs, output, remaps=(), settings=(),
        passthrough=("/truth/", "/chaser/camera/*/calibration"), record_timing=True, pairs=(),
        run_while=()):
    """Runs DFPC graphs over recordings to their end and records the products in `output`.

    remaps: "dfpc.input=/channel" to feed an input from another channel.
    settings: "[DFPC/]NODE.PARAM=VALUE" to set instance parameters without editing the graphs.
    passthrough: input channels copied to the output, by prefix or by pattern with * ? []
        (the ground truth and the cameras' calibrations by default).
    pairs: "/pair=/left/image,/right/image" to make stereo pairs from two image channels.
    run_while: "DFPC=TRACKER:STATE[,STATE]" to run a DFPC only while another's track state is
    one of those (detection while a tracker is UNINITIALISED or LOST).
    These are `cdff run`'s options --map, --set, --passthrough, --pair and --run-while; a graph
    may be a run set (graphs, maps, settings, pairs and rules in one file, docs/dfpc.md).
    Returns {"summary": ..., "dfpcs": [status, ...], "output": output}. Runs without the GIL.
    """
    from cdff._core import _dfpc
    return _dfpc.run(_paths(graphs), _paths(inputs), str(output), list(remaps), list(settings),
                     list(passthrough), record_timing, list(pairs), list(run_while))
