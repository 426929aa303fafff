"""Wrong input raises a clean exception naming the problem: shapes, dtypes, contiguity, values that
are not finite, indices and ranges; the library's own errors as lsnif.Error."""

import numpy as np
import pytest

import lsnif

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
F = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]], dtype=np.int32)


def test_mesh_arrays_are_checked():
    assert "4 triangles" in repr(lsnif.Mesh.from_arrays(V, F))
    with pytest.raises(TypeError, match="vertices must be a NumPy array"):
        lsnif.Mesh.from_arrays(V.tolist(), F)
    with pytest.raises(TypeError, match="float32 or float64"):
        lsnif.Mesh.from_arrays(V.astype(np.float16), F)
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        lsnif.Mesh.from_arrays(V[:, :2].copy(), F)
    with pytest.raises(ValueError, match="C-contiguous"):
        lsnif.Mesh.from_arrays(np.asfortranarray(V), F)
    bad = V.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"vertices\[2\] = \(0, nan, 0\) is not finite"):
        lsnif.Mesh.from_arrays(bad, F)
    with pytest.raises(ValueError, match=r"faces\[1\] indexes vertex 7 of 4"):
        lsnif.Mesh.from_arrays(V, np.array([[0, 1, 2], [0, 1, 7]]))
    with pytest.raises(ValueError, match="vertex -1"):
        lsnif.Mesh.from_arrays(V, np.array([[0, 1, -1]]))
    with pytest.raises(TypeError, match="faces must hold"):
        lsnif.Mesh.from_arrays(V, F.astype(np.float32))
    with pytest.raises(ValueError, match="normals must have one row per vertex"):
        lsnif.Mesh.from_arrays(V, F, normals=V[:3].copy())
    with pytest.raises(ValueError, match="empty"):
        lsnif.Mesh.from_arrays(V, np.zeros((0, 3), dtype=np.int32))
    # Every triangle degenerate: the library's error.
    with pytest.raises(lsnif.Error):
        lsnif.Mesh.from_arrays(np.zeros((3, 3), dtype=np.float32), np.array([[0, 1, 2]]))


def test_files_that_cannot_be_read_are_errors_naming_them(tmp_path):
    with pytest.raises(lsnif.Error, match="missing.off"):
        lsnif.Mesh.load(str(tmp_path / "missing.off"))
    junk = tmp_path / "junk.lsnif"
    junk.write_bytes(b"not a model at all")
    with pytest.raises(lsnif.Error, match="junk.lsnif"):
        lsnif.Model.load(str(junk))
    with pytest.raises(lsnif.Error):
        lsnif.Model.from_bytes(b"\x00" * 64)


def test_rays_are_checked(tiny_model):
    o = np.zeros((5, 3), dtype=np.float32)
    d = np.tile(np.float32([0, 0, 1]), (5, 1))
    assert tiny_model.intersect(o, d)["hit"].shape == (5,)
    assert tiny_model.intersect(o.astype(np.float64), d.astype(np.float64))["t"].dtype == np.float32
    with pytest.raises(ValueError, match=r"origins must have the shape \(N, 3\)"):
        tiny_model.intersect(o.reshape(-1), d)
    with pytest.raises(ValueError, match="as many rays"):
        tiny_model.intersect(o[:4], d)
    with pytest.raises(ValueError, match="C-contiguous"):
        tiny_model.intersect(np.zeros((5, 6), dtype=np.float32)[:, ::2], d)
    bad = d.copy()
    bad[3, 0] = np.inf
    with pytest.raises(ValueError, match=r"directions\[3\]"):
        tiny_model.intersect(o, bad)
    zero = d.copy()
    zero[1] = 0
    with pytest.raises(ValueError, match=r"directions\[1\] is zero"):
        tiny_model.intersect(o, zero)
    with pytest.raises(ValueError, match="tmin"):
        tiny_model.intersect(o, d, tmin=-1.0)
    with pytest.raises(ValueError, match="tmax"):
        tiny_model.intersect(o, d, tmin=2.0, tmax=1.0)
    with pytest.raises(ValueError, match="cull"):
        tiny_model.intersect(o, d, cull="sideways")
    with pytest.raises(ValueError, match="transform"):
        tiny_model.intersect(o, d, transform=np.eye(2))
    with pytest.raises(ValueError, match="last row"):
        tiny_model.intersect(o, d, transform=np.ones((4, 4)))
    with pytest.raises(lsnif.Error, match="singular"):
        tiny_model.intersect(o, d, transform=np.zeros((3, 4)))
    # Empty batches are fine.
    assert tiny_model.intersect(o[:0], d[:0])["hit"].shape == (0,)


def test_evaluation_and_images_are_checked(tiny_model, bunny):
    with pytest.raises(ValueError, match="rays"):
        lsnif.eval(tiny_model, bunny, rays=0)
    with pytest.raises(ValueError, match="rays"):
        lsnif.eval_rays(tiny_model, bunny, rays=lsnif.MAX_EVAL_RAYS + 1)
    img = np.zeros((4, 5, 3), dtype=np.float32)
    with pytest.raises(ValueError, match=r"reference must have the shape \(H, W, 3\)"):
        lsnif.flip(img[:, :, 0].copy(), img)
    with pytest.raises(lsnif.Error):
        lsnif.flip(img, np.zeros((4, 6, 3), dtype=np.float32))
    with pytest.raises(ValueError, match="pixels_per_degree"):
        lsnif.flip(img, img, pixels_per_degree=0.0)
    with pytest.raises(ValueError, match=r"rays = -1 is out of range"):
        lsnif.eval(tiny_model, bunny, rays=-1)
    with pytest.raises(TypeError, match="rays must be an int"):
        lsnif.eval(tiny_model, bunny, rays=10.5)
    with pytest.raises(ValueError, match="seed"):
        lsnif.eval_rays(tiny_model, bunny, rays=10, seed=-3)
    with pytest.raises(lsnif.Error, match="nothing.png"):
        lsnif.load_image("/nonexistent/nothing.png")
