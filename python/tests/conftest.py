"""Finds the package in the build tree when the tests run outside CTest (which sets PYTHONPATH)."""
import os
import pathlib
import sys

try:
    import cdff  # noqa: F401
except ImportError:
    build = os.environ.get("CDFF_BUILD_DIR",
                           str(pathlib.Path(__file__).resolve().parents[2] / "build"))
    sys.path.insert(0, str(pathlib.Path(build) / "python"))
