"""Recordings (MCAP, docs/recording.md) from Python.

    for msg in cdff.io.read("run.mcap", channels=["/cdff/lidar_tracking/pose"]):
        print(msg.channel, msg.stamp, msg.value)

    with cdff.io.Writer("out.mcap") as w:
        w.write("/chaser/camera/image", cdff.Image(array, stamp=t))

A damaged (truncated) file yields every message before the damage, then raises
cdff.CorruptDataError saying where the damage is.
"""
from cdff._core._io import Message, Reader, Writer

__all__ = ["Message", "Reader", "Writer", "read", "channels"]


def read(paths, channels=(), start=None, end=None):
    """The messages of one MCAP file (or a list of files, merged in log-time order), optionally
    only `channels` and the log times [start, end] (µs)."""
    return Reader(paths, list(channels), start, end)


def channels(paths):
    """The channels of one or several recordings: dicts of channel, type, schema, message_count."""
    return Reader(paths).channels
