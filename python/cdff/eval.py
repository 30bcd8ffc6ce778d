"""Evaluation of a run's recording against its ground truth (docs/evaluation.md).

    report = cdff.eval.evaluate(["run.mcap"])
    for product in report["products"]: ...

Returns the JSON document `cdff eval --json` writes (as Python dicts and lists), plus "notes":
what the recording holds that the evaluation could not use.
"""
import os

from cdff._core import _eval

__all__ = ["evaluate"]


def evaluate(recordings, statistic="p95", max_truth_gap_s=0.5, products=(), pairs=None,
             focal_px=None, camera=""):
    """Pairs each pose or bearing product of the recordings with its truth channel and measures it.

    statistic: "p95", "max" or "rmse", for the requirement verdicts.
    max_truth_gap_s: the longest truth gap across which truth is interpolated.
    products: only these product channels (default: every pose product).
    pairs: {product channel: truth channel} instead of pairing by frames.
    focal_px, camera: the focal length of bearings' errors in pixels, given or from that camera
        calibration channel (default: the recordings' only camera calibration).
    """
    if isinstance(recordings, (str, os.PathLike)):
        recordings = [recordings]
    return _eval.evaluate([str(r) for r in recordings], statistic, max_truth_gap_s,
                          list(products), dict(pairs or {}), focal_px, str(camera))
