#!/usr/bin/env python3
"""Trains an LSNIF model from NumPy arrays, intersects a grid of camera rays with it and with the
exact mesh, and writes their depth and normals side by side (matplotlib).

    PYTHONPATH=build/python python3 samples/python/depth_normals.py            # the bunny, the default model
    PYTHONPATH=build/python python3 samples/python/depth_normals.py --mesh M.off --steps 600 --out pic.png
"""

import argparse
import os
import pathlib
import sys
import time

import lsnif  # first: where this interpreter has no NumPy, lsnif finds the one it was built with

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent


def read_off(path):
    """Vertices (V, 3) and triangles (F, 3) of an OFF file, parsed with NumPy (polygons fanned)."""
    words = [w for line in pathlib.Path(path).read_text().splitlines() for w in line.split("#")[0].split()]
    if not words or words[0] != "OFF":
        sys.exit("%s: not an OFF file" % path)
    nv, nf = int(words[1]), int(words[2])
    vertices = np.array(words[4:4 + 3 * nv], dtype=np.float64).reshape(nv, 3)
    faces, at = [], 4 + 3 * nv
    for _ in range(nf):
        k = int(words[at])
        ring = [int(w) for w in words[at + 1:at + 1 + k]]
        faces += [[ring[0], ring[i], ring[i + 1]] for i in range(1, k - 1)]
        at += 1 + k
    return vertices, np.array(faces, dtype=np.int64)


def camera_rays(lo, hi, size):
    """A pinhole camera looking at the box's centre from the front-right, size x size rays."""
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    eye = centre + radius * np.array([1.2, 0.6, 2.2])
    forward = (centre - eye) / np.linalg.norm(centre - eye)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    s = np.linspace(-1, 1, size) * np.tan(np.radians(20))
    x, y = np.meshgrid(s, -s)
    directions = forward + x[..., None] * right + y[..., None] * up
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    origins = np.broadcast_to(eye, directions.shape)
    return np.ascontiguousarray(origins.reshape(-1, 3), np.float32), np.ascontiguousarray(directions.reshape(-1, 3), np.float32)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mesh", default=str(HERE.parents[1] / "data" / "meshes" / "bunny00.off"), help="an OFF mesh")
    parser.add_argument("--steps", type=int, help="training steps (default: the default model's, lsnif.settings())")
    parser.add_argument("--size", type=int, default=256, help="picture side in pixels, 16 to 2048")
    parser.add_argument("--out", default="out/depth_normals.png", help="the picture (.png)")
    args = parser.parse_args()
    if not 16 <= args.size <= 2048:
        sys.exit("--size must lie in [16, 2048], not %d" % args.size)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    vertices, faces = read_off(args.mesh)
    mesh = lsnif.Mesh.from_arrays(vertices, faces, name=pathlib.Path(args.mesh).name)
    t0 = time.time()

    def progress(step, steps, loss):
        if step % 100 == 0 or step == steps:
            print("step %5d / %d  loss %.4f  (%.1f s)" % (step, steps, loss, time.time() - t0), flush=True)

    settings = {} if args.steps is None else {"steps": args.steps}  # checked by lsnif.train: ValueError out of range
    model = lsnif.train(mesh, progress=progress, **settings)
    print("trained: %s, %.3f MiB" % (model.config, model.memory["total"] / 2**20))

    origins, directions = camera_rays(*model.bounds, args.size)
    ours = model.intersect(origins, directions)
    exact = lsnif.reference_intersect(mesh, origins, directions)
    both = ours["hit"] & exact["hit"]
    print("camera rays: %d hit the mesh, %d the model; %.2f%% agree on hit or miss"
          % (exact["hit"].sum(), ours["hit"].sum(), 100 * np.mean(ours["hit"] == exact["hit"])))
    if both.any():
        err = np.degrees(np.arccos(np.clip(np.sum(ours["normal"][both] * exact["normal"][both], axis=1), -1, 1)))
        print("normal error median %.2f deg" % np.median(err))

    near, far = (np.percentile(exact["t"][exact["hit"]], [0, 100]) if exact["hit"].any() else (0, 1))
    fig, axes = plt.subplots(2, 2, figsize=(8, 8))
    for row, (name, h) in enumerate([("LSNIF", ours), ("exact (Embree)", exact)]):
        depth = np.where(h["hit"], (h["t"] - near) / max(far - near, 1e-9), np.nan).reshape(args.size, args.size)
        normal = np.where(h["hit"][:, None], (h["normal"] + 1) / 2, 1.0).reshape(args.size, args.size, 3)
        axes[row, 0].imshow(depth, cmap="viridis_r", vmin=0, vmax=1)
        axes[row, 0].set_title("%s depth" % name)
        axes[row, 1].imshow(np.clip(normal, 0, 1))
        axes[row, 1].set_title("%s normal" % name)
    for ax in axes.flat:
        ax.set_axis_off()
    fig.tight_layout()
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_name(out.name + ".partial")  # never a half-written picture under the name asked for
    fig.savefig(partial, dpi=100, format="png")
    os.replace(partial, out)
    print("wrote %s" % out)


if __name__ == "__main__":
    main()
