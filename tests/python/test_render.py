"""lsnif.render against the lsnif program's render of the same scene, lsnif.flip against its FLIP,
and image files."""

import numpy as np
import pytest

import lsnif
from conftest import ROOT, run_cli, run_cli_json

SCENE = ROOT / "samples" / "scenes" / "bunny_on_plane.gltf"
SIZE = dict(width=48, height=32, spp=2)


def test_render_is_the_programs_render(tiny_model_path, tmp_path):
    image = lsnif.render(str(SCENE), models={"bunny": str(tiny_model_path)}, **SIZE)
    assert image.shape == (32, 48, 3) and image.dtype == np.float32
    assert np.all(np.isfinite(image)) and image.max() > 0.05
    out = tmp_path / "cli.hdr"
    run_cli("render", SCENE, "--lsnif", "bunny=%s" % tiny_model_path, "-o", out, "--width", 48, "--height", 32,
            "--spp", 2)
    cli = lsnif.load_image(str(out))
    # Radiance HDR keeps 8 bits of mantissa per pixel: equal within that.
    assert np.allclose(image, cli, rtol=1.0 / 64, atol=1e-3)


def test_flip_is_the_programs_flip(tiny_model_path, tmp_path):
    a = lsnif.render(str(SCENE), models={"bunny": str(tiny_model_path)}, **SIZE)
    b = a * np.float32(0.8)
    lsnif.save_image(str(tmp_path / "a.png"), a)
    lsnif.save_image(str(tmp_path / "b.png"), b)
    cli = run_cli_json("flip", tmp_path / "a.png", tmp_path / "b.png", "--json")
    py = lsnif.flip(lsnif.load_image(str(tmp_path / "a.png")), lsnif.load_image(str(tmp_path / "b.png")))
    assert py["error"].shape == (32, 48) and py["heatmap"].shape == (32, 48, 3)
    # The same FLIP of the same files; the program reads PNG through OpenImageIO, the module through
    # stb, whose sRGB decodings differ in the last bits.
    assert abs(py["mean"] - cli["mean"]) <= 2e-5 * cli["mean"]
    assert cli["mean"] > 0.01
    assert lsnif.flip(a, a)["mean"] == 0.0


def test_render_options_are_checked(tiny_model_path):
    models = {"bunny": str(tiny_model_path)}
    with pytest.raises(ValueError, match="width"):
        lsnif.render(str(SCENE), models=models, width=0)
    with pytest.raises(ValueError, match="height = -5 is out of range"):
        lsnif.render(str(SCENE), models=models, height=-5)
    with pytest.raises(TypeError, match="camera must be an int"):
        lsnif.render(str(SCENE), models=models, camera="main", **SIZE)
    with pytest.raises(ValueError, match="spp"):
        lsnif.render(str(SCENE), models=models, spp=0)
    with pytest.raises(ValueError, match="pipeline"):
        lsnif.render(str(SCENE), models=models, pipeline="fast")
    with pytest.raises(ValueError, match="camera"):
        lsnif.render(str(SCENE), models=models, camera=5, **SIZE)
    with pytest.raises(lsnif.Error, match="nowhere.gltf"):
        lsnif.render("nowhere.gltf")
    with pytest.raises(lsnif.Error, match="ghost"):
        lsnif.render(str(SCENE), models={"ghost": str(tiny_model_path)}, **SIZE)
