"""``evaluator=auto`` (the default): the OpenCL evaluator where it works here, else NumPy.

The rule: ``opencl`` when pyopencl imports, an OpenCL platform has a device, and on that
device the kernel builds and counts a small test scene exactly as ``numpy`` does; ``numpy``
otherwise. The check runs once per process (about a second, nearly all of it the kernel's
build, which the OpenCL evaluator then reuses). Both backends count the same pixels (the
conformance suite), so the choice changes the speed, never a result.

The choice and its reason are logged in one line; the evaluator returned is the chosen
backend's own, whose ``name`` (``"opencl"`` or ``"numpy"``) the run summary reports as its
``backend``.
"""
from __future__ import annotations

import logging
from functools import cache

import numpy as np

from mmocap.camera import Camera
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.evaluators.opencl import OpenCLEvaluator
from mmocap.evaluators.silhouette import PATCH_SCALE

log = logging.getLogger(__name__)


def auto_evaluator(patch_scale: float = PATCH_SCALE):
    """The evaluator :func:`choose` picks, with this ``patch_scale`` (factor on the body's
    per-joint patch size, Cano Eq. 4, > 0)."""
    name, reason = choose()
    log.info("evaluator=auto chose %s: %s", name, reason)
    backend = OpenCLEvaluator if name == "opencl" else NumpyEvaluator
    return backend(patch_scale)


@cache
def choose() -> tuple[str, str]:
    """``("opencl" or "numpy", why)``, decided once per process (see the module's doc)."""
    reason = OpenCLEvaluator.unavailable()
    if reason:
        return "numpy", f"OpenCL is unavailable: {reason}"
    try:
        return check_opencl()
    except Exception as err:  # noqa: BLE001 - whatever fails, this machine falls back to NumPy
        message = str(err).strip().splitlines()[0] if str(err).strip() else ""
        return "numpy", f"the OpenCL check failed: {type(err).__name__}: {message}"


def check_opencl() -> tuple[str, str]:
    """Count a small scene with the default OpenCL device and with NumPy: ``("opencl", the
    device)`` when the counts are equal, else ``("numpy", how they differ)``."""
    body, camera, foreground, X = _test_scene()
    with OpenCLEvaluator() as opencl, NumpyEvaluator() as reference:
        device = opencl.devices[0]
        for ev in (opencl, reference):
            ev.setup(body, [camera], [foreground])
        got, expected = opencl.counts(X), reference.counts(X)
    where = f"{device.name.strip()} ({device.platform.name})"
    if all(np.array_equal(g, e) for g, e in zip(got, expected)):
        return "opencl", f"OpenCL device {where} counts a test scene exactly as numpy does"
    return "numpy", (f"OpenCL device {where} counts a test scene differently from numpy "
                     f"(model pixels {got[0].ravel().tolist()}, numpy's "
                     f"{expected[0].ravel().tolist()})")


class _Ball:
    """A ball of 300 vertices, radius 100 mm, on one joint; pose (3,): its centre in mm."""

    def __init__(self, count: int = 300, radius: float = 100.0):
        i = np.arange(count) + 0.5  # a Fibonacci sphere
        polar, azimuth = np.arccos(1 - 2 * i / count), np.pi * (1 + 5 ** 0.5) * i
        self.rest_normals = np.stack([np.sin(polar) * np.cos(azimuth), np.cos(polar),
                                      np.sin(polar) * np.sin(azimuth)], axis=1)
        self.rest_vertices = radius * self.rest_normals
        self.vertex_joint = np.zeros(count, int)
        self.joint_rest_positions = np.zeros((1, 3))
        self.patch_mm = np.array([radius * np.sqrt(2 * np.pi / count)])

    def transforms(self, X: np.ndarray) -> np.ndarray:
        X = np.atleast_2d(X)
        T = np.tile(np.eye(4), (len(X), 1, 1, 1))
        T[:, 0, :3, 3] = X[:, :3]
        return T


def _test_scene():
    """A ball seen by a 64x48 camera 1 m away against a half-image foreground, and poses
    that put it in the middle, near a corner and half out of the image."""
    camera = Camera.look_at("auto-check", (0, 0, -1000), (0, 0, 0), 200.0, 64, 48)
    foreground = np.zeros((48, 64), bool)
    foreground[:, :32] = True
    X = np.array([[0.0, 0.0, 0.0], [-60.0, 45.0, 20.0], [-130.0, 0.0, -30.0]])
    return _Ball(), camera, foreground, X
