"""The package as a user gets it: type stubs for every compiled class and generated DFN class,
docstrings from the descriptions, and `cmake --install` giving an importable copy."""
import ast
import inspect
import os
import pathlib
import subprocess
import sys

import pytest

import cdff
from cdff import _core

PACKAGE = pathlib.Path(cdff.__file__).parent


def stub_names(path):
    tree = ast.parse(path.read_text())
    return {node.name for node in tree.body if isinstance(node, (ast.ClassDef, ast.FunctionDef))}


def test_stubs_cover_the_compiled_module():
    names = stub_names(PACKAGE / "_core" / "__init__.pyi")
    public = {n for n, o in vars(_core).items()
              if not n.startswith("_") and (inspect.isclass(o) or callable(o))}
    assert public - names == set()
    for sub in ("_io", "_sim", "_eval", "_dfpc"):
        module = getattr(_core, sub)
        names = stub_names(PACKAGE / "_core" / f"{sub}.pyi")
        assert {n for n in vars(module) if not n.startswith("_")} - names == set()


def test_stubs_of_the_generated_dfn_classes():
    names = stub_names(PACKAGE / "dfn.pyi")
    assert set(cdff.dfn.__all__) <= names
    tree = ast.parse((PACKAGE / "dfn.pyi").read_text())
    canny = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "EdgeDetection")
    init = next(n for n in canny.body if isinstance(n, ast.FunctionDef) and n.name == "__init__")
    assert "low_threshold" in {a.arg for a in init.args.kwonlyargs}


def test_docstrings_come_from_the_descriptions():
    doc = cdff.dfn.EdgeDetection.__doc__
    assert "Canny" in doc and "low_threshold" in doc and "Inputs:" in doc
    assert cdff.dfn.EdgeDetection.Inputs.image.__doc__


@pytest.mark.skipif(not os.environ.get("CDFF_BUILD_DIR"), reason="needs the CMake build (CTest)")
def test_cmake_install_gives_an_importable_package(tmp_path):
    build = os.environ["CDFF_BUILD_DIR"]
    subprocess.run(["cmake", "--install", build, "--component", "python", "--prefix", tmp_path],
                   check=True, capture_output=True)
    site = tmp_path / os.environ["CDFF_PYTHON_INSTALL_DIR"]
    code = ("import numpy as np, cdff; c = cdff.dfn.EdgeDetection('Canny'); "
            "c.image = cdff.Image(np.zeros((8, 8), np.uint8)); c.process(); print(cdff.__file__)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(site)}, cwd=tmp_path).stdout
    assert out.strip().startswith(str(site))
