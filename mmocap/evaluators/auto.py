"""``evaluator=auto`` (the default): the OpenCL evaluator where it works here, else NumPy.

The rule: ``opencl`` when pyopencl imports, an OpenCL platform has a device, and on that
device the kernel builds and passes the OpenCL evaluator's self-check (a small test scene
counted exactly as ``numpy`` does); ``numpy`` otherwise. The check runs once per process
(about a second, nearly all of it the kernel's build, which the OpenCL evaluator then
reuses). Both backends count the same pixels (the
conformance suite), so the choice changes the speed, never a result.

The choice and its reason are logged in one line; the evaluator returned is the chosen
backend's own, whose ``name`` (``"opencl"`` or ``"numpy"``) the run summary reports as its
``backend``.
"""

from __future__ import annotations

import logging
from functools import cache

from mmocap.errors import ConfigError
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
    """The default OpenCL evaluator's self-check (:mod:`mmocap.evaluators.opencl`: a test
    scene counted on the device and with NumPy): ``("opencl", the device)`` when the counts
    are equal, else ``("numpy", how they differ)``."""
    try:
        opencl = OpenCLEvaluator()
    except ConfigError as err:
        return "numpy", str(err)
    return "opencl", f"OpenCL device {opencl.where} counts a test scene exactly as numpy does"
