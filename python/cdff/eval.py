"""Evaluation of a run's recording against its ground truth (docs/evaluation.md).

    report = cdff.eval.evaluate(["run.mcap"])
    for product in report["products"]: ...

Returns the JSON document `cdff eval --json` writes (as Python dicts and lists), plus "notes":
what the recording holds that the evaluation could not use.
"""
import os

from cdff._core import _eval

__all__ = ["evaluate"]


def evaluate(recordings, statistic="p95", max_truth_gap_s=0.5, products=(), pairs=None):
    """Pairs each pose product of the recordings with its truth channel and measures it.

    statistic: "p95", "max" or "rmse", for the requirement verdicts.
    max_truth_gap_s: the longest truth gap across which truth is interpolated.
    products: only these product channels (default: every pose product).
    pairs: {product channel: truth channel} instead of pairing by frames.
    """
    if isinstance(recordings, (str, os.PathLike)):
        recordings = [recordings]
    return _eval.evaluate([str(r) for r in recordings], statistic, max_truth_gap_s,
                          list(products), dict(pairs or {}))
