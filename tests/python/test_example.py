"""The example (samples/python/depth_normals.py) runs and writes its picture."""

import os
import subprocess
import sys

import lsnif
from conftest import BUNNY, ROOT


def test_the_example_writes_its_picture(tmp_path):
    out = tmp_path / "pictures" / "depth_normals.png"
    r = subprocess.run([sys.executable, str(ROOT / "samples" / "python" / "depth_normals.py"), "--mesh", str(BUNNY),
                        "--steps", "30", "--size", "32", "--out", str(out)],
                       capture_output=True, text=True, env=os.environ.copy())
    assert r.returncode == 0, r.stdout + r.stderr
    assert "wrote %s" % out in r.stdout
    picture = lsnif.load_image(str(out))
    assert picture.shape == (800, 800, 3)
    assert picture.std() > 0.05  # not a blank page
    assert sorted(p.name for p in out.parent.iterdir()) == ["depth_normals.png"]


def test_the_example_refuses_a_size_out_of_range(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "samples" / "python" / "depth_normals.py"), "--size", "5",
                        "--out", str(tmp_path / "x.png")], capture_output=True, text=True, env=os.environ.copy())
    assert r.returncode != 0 and "--size" in r.stderr
    assert not (tmp_path / "x.png").exists()
