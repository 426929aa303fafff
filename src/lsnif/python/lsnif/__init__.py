"""LSNIF, the Locally-Subdivided Neural Intersection Function, from Python (docs/python.md).

Meshes from files or NumPy arrays, training with the tools' settings as keyword arguments, models
loaded and saved as .lsnif files, rays intersected on the CPU reference intersector or on a Vulkan
device through the plugin's batched path, evaluation against exact ray casting, path-traced renders
and FLIP::

    import numpy as np, lsnif
    mesh = lsnif.Mesh.from_arrays(vertices, faces)        # (V, 3) float, (F, 3) int
    model = lsnif.train(mesh, steps=600, progress=print)   # the GIL is released; Ctrl-C stops it
    hits = model.intersect(origins, directions)            # dict of arrays: hit, t, normal, albedo, ...
    print(lsnif.eval(model, mesh)["model"]["accuracy"])

Errors of the library are raised as lsnif.Error (a RuntimeError) with its message; arrays of the
wrong shape or dtype, values that are not finite and settings out of range raise TypeError or
ValueError naming the argument.
"""

import sys as _sys

from . import _build_info

try:
    import numpy  # noqa: F401  (the extension's arrays are NumPy arrays)
except ImportError:
    # An interpreter without NumPy of the version this build is for (e.g. a pyenv Python 3.11 beside
    # Debian's): the NumPy of the interpreter the build found serves it (the same ABI), and
    # numpy_dir tells which one was used.
    _here = "%d.%d" % _sys.version_info[:2]
    if _here != _build_info.python_version:
        raise ImportError(
            "lsnif was built for Python %s (%s) and NumPy; this is Python %s without NumPy: run %s, "
            "or rebuild with -DPython3_EXECUTABLE=%s"
            % (_build_info.python_version, _build_info.python, _here, _build_info.python, _sys.executable)
        ) from None
    _sys.path.append(_build_info.numpy_dir)
    try:
        import numpy  # noqa: F401
    except ImportError as _e:
        raise ImportError(
            "lsnif needs NumPy: neither this interpreter (%s) nor the one it was built for (%s, NumPy in %s) "
            "provides it: install python3-numpy (scripts/setup.sh does)"
            % (_sys.executable, _build_info.python, _build_info.numpy_dir)
        ) from _e

try:
    from ._lsnif import (  # noqa: F401
        MAX_EVAL_RAYS,
        MAX_THREADS,
        Device,
        Error,
        Mesh,
        Model,
        __version__,
        eval,
        eval_rays,
        flip,
        load_image,
        reference_intersect,
        render,
        save_image,
        settings,
        train,
    )
except ImportError as _e:
    raise ImportError(
        "lsnif's extension does not load in this interpreter (%s, Python %d.%d; built for %s, Python %s): %s"
        % (_sys.executable, _sys.version_info[0], _sys.version_info[1], _build_info.python,
           _build_info.python_version, _e)
    ) from _e

numpy_dir = numpy.__path__[0]

__all__ = [
    "Device", "Error", "Mesh", "Model", "MAX_EVAL_RAYS", "MAX_THREADS", "eval", "eval_rays", "flip",
    "load_image", "reference_intersect", "render", "save_image", "settings", "train",
]
