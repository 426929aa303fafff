"""Model.intersect on a Vulkan device (the plugin's batched path; lavapipe in CI, with the validation
layer) against the CPU reference intersector, ray by ray."""

import numpy as np
import pytest

import lsnif


def rays_at(model, count, seed):
    rng = np.random.default_rng(seed)
    lo, hi = model.bounds
    centre, size = (lo + hi) / 2, np.linalg.norm(hi - lo)
    origins = (centre + rng.normal(size=(count, 3)) * size).astype(np.float32)
    directions = (centre + rng.uniform(-0.35, 0.35, size=(count, 3)) * size - origins).astype(np.float32)
    return origins, directions


def assert_same_hits(device_hits, cpu_hits, origins, directions, diag):
    dev, cpu = device_hits, cpu_hits
    agree = dev["hit"] == cpu["hit"]
    # Where they disagree the network sits on its threshold: occlusion 0.5 within fp16 inference's error.
    borderline = np.abs(cpu["occlusion"] - 0.5) < 0.01
    assert np.all(agree | borderline), np.flatnonzero(~agree & ~borderline)[:10]
    assert agree.mean() >= 0.999
    both = dev["hit"] & cpu["hit"]
    assert both.sum() > 200
    length = np.linalg.norm(directions[both], axis=1)
    assert np.all(np.abs(dev["t"][both] - cpu["t"][both]) * length <= 2e-4 * diag)
    cos = np.sum(dev["normal"][both] * cpu["normal"][both], axis=1)
    assert np.percentile(cos, 1) > np.cos(np.radians(1.0))
    assert np.mean(dev["material"][both] == cpu["material"][both]) > 0.999
    assert np.abs(dev["albedo"][both] - cpu["albedo"][both]).max() < 2e-2
    assert np.abs(dev["occlusion"] - cpu["occlusion"]).max() < 2e-2


@pytest.fixture(scope="module")
def device():
    with lsnif.Device(validation=True) as d:
        yield d


def test_the_device_path_agrees_with_the_cpu_ray_by_ray(tiny_model, device):
    origins, directions = rays_at(tiny_model, 6000, 1)
    lo, hi = tiny_model.bounds
    diag = float(np.linalg.norm(hi - lo))
    cpu = tiny_model.intersect(origins, directions)
    dev = tiny_model.intersect(origins, directions, device=device)
    assert set(dev) == set(cpu)
    assert_same_hits(dev, cpu, origins, directions, diag)


def test_the_device_path_agrees_under_a_transform_and_culling(tiny_model, device):
    origins, directions = rays_at(tiny_model, 6000, 2)
    xf = np.array([[0.0, -1.5, 0.2, 4.0], [1.5, 0.0, 0.0, -1.0], [0.0, 0.3, 1.2, 0.5]])
    a, t = xf[:, :3], xf[:, 3]
    world_o = (origins @ a.T + t).astype(np.float32)
    world_d = (directions @ a.T).astype(np.float32)
    lo, hi = tiny_model.bounds
    diag = float(np.linalg.norm((hi - lo) @ a.T))
    for cull in ("none", "back"):
        cpu = tiny_model.intersect(world_o, world_d, transform=xf, cull=cull)
        dev = tiny_model.intersect(world_o, world_d, transform=xf, cull=cull, device=device)
        assert_same_hits(dev, cpu, world_o, world_d, diag)


def test_a_device_is_chosen_by_name_or_index(tiny_model):
    origins, directions = rays_at(tiny_model, 100, 3)
    by_index = tiny_model.intersect(origins, directions, device=0)
    with lsnif.Device("0") as d:
        by_name = tiny_model.intersect(origins, directions, device=lsnif.Device(d.name.split()[0]))
    assert np.array_equal(by_index["hit"], by_name["hit"])
    with pytest.raises(lsnif.Error, match="no-such-gpu"):
        lsnif.Device("no-such-gpu")
    with pytest.raises(TypeError, match="device"):
        tiny_model.intersect(origins, directions, device=1.5)
    closed = lsnif.Device()
    closed.close()
    with pytest.raises(lsnif.Error, match="closed"):
        tiny_model.intersect(origins, directions, device=closed)
