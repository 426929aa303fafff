"""Model.intersect on the CPU against the lsnif program's evaluation of the same rays, and the
transform of an instance."""

import numpy as np

import lsnif
from conftest import BUNNY, run_cli_json

RAYS = 4000


def percentile(values, q):
    """The evaluation's percentile: the element at round(q (n - 1)) of the sorted values."""
    v = np.sort(values)
    return float(v[int(np.floor(q * (len(v) - 1) + 0.5))])


def test_intersect_on_the_held_out_rays_gives_the_programs_eval(tiny_model, tiny_model_path, bunny):
    cli = run_cli_json("eval", tiny_model_path, BUNNY, "--rays", RAYS, "--json")["model"]
    origins, directions = lsnif.eval_rays(tiny_model, bunny, rays=RAYS)
    assert origins.shape == directions.shape == (RAYS, 3) and origins.dtype == np.float32
    hits = tiny_model.intersect(origins, directions)
    ref = lsnif.reference_intersect(bunny, origins, directions)
    both = hits["hit"] & ref["hit"]
    assert int(both.sum()) == cli["true_hits"]
    assert int((hits["hit"] & ~ref["hit"]).sum()) == cli["false_hits"]
    assert int((~hits["hit"] & ~ref["hit"]).sum()) == cli["true_misses"]
    assert int((~hits["hit"] & ref["hit"]).sum()) == cli["false_misses"]
    lo, hi = tiny_model.bounds
    diag = float(np.linalg.norm((hi - lo).astype(np.float32)))
    t_err = np.abs(hits["t"][both].astype(np.float64) - ref["t"][both]) / diag
    assert abs(percentile(t_err, 0.5) - cli["t_error_median"]) <= 1e-6 * cli["t_error_median"]
    assert abs(percentile(t_err, 0.9) - cli["t_error_p90"]) <= 1e-6 * cli["t_error_p90"]
    cos = np.clip(np.sum(hits["normal"][both].astype(np.float64) * ref["normal_mapped"][both], axis=1), -1, 1)
    n_err = np.degrees(np.arccos(cos))
    assert abs(percentile(n_err, 0.5) - cli["normal_error_median_deg"]) < 1e-3
    # lsnif.eval is the program's evaluation.
    assert lsnif.eval(tiny_model, bunny, rays=RAYS)["model"] == cli


def test_an_instance_transform_moves_the_hits(tiny_model):
    rng = np.random.default_rng(3)
    lo, hi = tiny_model.bounds
    centre = (lo + hi) / 2
    origins = (centre + rng.normal(size=(2000, 3)) * np.linalg.norm(hi - lo)).astype(np.float32)
    directions = (centre + rng.uniform(-0.3, 0.3, size=(2000, 3)) - origins).astype(np.float32)
    plain = tiny_model.intersect(origins, directions)
    # object -> world: rotation about z by 30 degrees, scale 2, translation (1, -2, 3).
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    a = 2.0 * np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    xf = np.hstack([a, [[1], [-2], [3]]])
    moved = tiny_model.intersect(origins @ a.T + xf[:, 3], directions @ a.T, transform=xf)
    assert plain["hit"].sum() > 100
    agree = plain["hit"] == moved["hit"]
    assert agree.mean() > 0.999
    both = plain["hit"] & moved["hit"]
    # The world rays map back to the object rays up to float rounding, which moves a few walks' points
    # and so their predictions a little: nearly all hits are the same to rounding.
    t_rel = np.abs(moved["t"][both] - plain["t"][both]) / plain["t"][both]
    assert np.percentile(t_rel, 99) < 1e-4 and t_rel.max() < 0.05
    rotated = plain["normal"][both] @ (a / 2.0).T
    cos = np.sum(moved["normal"][both] * rotated, axis=1)
    assert np.percentile(cos, 1) > np.cos(np.radians(0.05)) and cos.min() > np.cos(np.radians(10))
    # 4 x 4 form: the same.
    xf4 = np.vstack([xf, [0, 0, 0, 1]])
    again = tiny_model.intersect(origins @ a.T + xf[:, 3], directions @ a.T, transform=xf4)
    assert np.array_equal(again["hit"], moved["hit"])
