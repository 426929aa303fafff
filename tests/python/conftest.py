"""Fixtures of the Python module's tests (tests/python, run by CTest's `python` test): the module
from the build tree (PYTHONPATH), the lsnif program of the same build (LSNIF_BIN) and the test
meshes (LSNIF_DATA, fetched by scripts/setup.sh)."""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import lsnif

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = pathlib.Path(os.environ.get("LSNIF_DATA", ROOT / "data"))
BUNNY = DATA / "meshes" / "bunny00.off"


def lsnif_bin():
    path = os.environ.get("LSNIF_BIN")
    if not path:
        raise RuntimeError("LSNIF_BIN must name the lsnif program of the build under test (CTest sets it)")
    return path


def run_cli(*args):
    """Runs the lsnif program; fails the test with its output when it exits non-zero."""
    r = subprocess.run([lsnif_bin(), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, "lsnif %s failed (%d):\n%s%s" % (" ".join(map(str, args)), r.returncode, r.stdout, r.stderr)
    return r.stdout


def run_cli_json(*args):
    return json.loads(run_cli(*args))


def read_off(path):
    """An OFF file's vertices (float64) and triangles (int64), parsed here, independently of the library."""
    words = pathlib.Path(path).read_text().split()
    assert words[0] == "OFF"
    nv, nf = int(words[1]), int(words[2])
    at = 4
    vertices = np.array(words[at:at + 3 * nv], dtype=np.float64).reshape(nv, 3)
    at += 3 * nv
    faces = []
    for _ in range(nf):
        k = int(words[at])
        assert k == 3, "the test meshes are triangle meshes"
        faces.append([int(w) for w in words[at + 1:at + 4]])
        at += 1 + k
    return vertices, np.array(faces, dtype=np.int64)


@pytest.fixture(scope="session")
def bunny():
    return lsnif.Mesh.load(str(BUNNY))


@pytest.fixture(scope="session")
def tiny_model(bunny):
    """A model trained in about a second (the tools' --tiny with 400 steps: 30 predict no hit)."""
    return lsnif.train(bunny, tiny=True, steps=400)


@pytest.fixture(scope="session")
def tiny_model_path(tiny_model, tmp_path_factory):
    path = tmp_path_factory.mktemp("models") / "bunny.lsnif"
    tiny_model.save(str(path))
    return path
