"""OpenCL devices for the OpenCL evaluators: pyopencl on first use, platforms, devices,
contexts, sub-devices and the kernel's programs.

pyopencl is imported on first use (:func:`pyopencl`), not when this module is imported, so
that mmocap and ``mmocap list`` work without it; :func:`unavailable` says why OpenCL cannot
be used here, with what to install.

Devices: ``platform`` is an index into ``pyopencl.get_platforms()`` or a case-insensitive
part of a platform's name (``"portable"`` for PoCL, ``"nvidia"``, ``"intel"``), None for the
first platform that has a GPU, else the first that has a device, never a simulator
(:data:`SIMULATORS`: Oclgrind, which checks the kernel's memory accesses hundreds of times
slower than a device runs it, is chosen by name only); ``device`` is an index into that platform's devices. PoCL, the
CPU platform, comes from PyPI (``pocl-binary-distribution``), so a machine without any
system OpenCL driver still has one. No platform, or an index that does not exist, is a
:class:`~mmocap.errors.ConfigError` that lists what there is: there is no silent fallback
(``evaluator=auto`` is the one that falls back to NumPy).

Programs are built once per process, context and build options (cached here), from
``kernels/silhouette.cl`` read as package data. PoCL also keeps compiled kernels on disk
in ``POCL_CACHE_DIR``: before pyopencl is imported, this module points it at a private
temporary folder per process, so that parallel runs of a sweep never share one, and pins
PoCL's worker threads to cores (``POCL_AFFINITY=1``) unless that variable is already set.
Both take effect only if nothing else started OpenCL in the process before.
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from importlib import resources

import numpy as np

from mmocap.errors import ConfigError

INSTALL = "pip install pyopencl pocl-binary-distribution"
#: parts of the names of platforms that platform=None never chooses
SIMULATORS = ("oclgrind",)
_PID_VAR = "MMOCAP_POCL_CACHE_PID"
_cl = None  # the pyopencl module, once imported
_CONTEXTS: dict[tuple, object] = {}
_PROGRAMS: dict[tuple, object] = {}
_SUB_DEVICES: dict[tuple, list] = {}
_VECTOR_BITS: dict[int, int] = {}
#: a kernel that writes the width in bits of the float vector registers its compiler targets
#: (x86: AVX-512, AVX or SSE), 0 where the compiler does not say
_VECTOR_BITS_PROBE = """
__kernel void vector_bits(__global int *out)
{
#if defined(__AVX512F__)
    out[0] = 512;
#elif defined(__AVX__)
    out[0] = 256;
#elif defined(__SSE__)
    out[0] = 128;
#else
    out[0] = 0;
#endif
}
"""


def _private_pocl_cache() -> None:
    """Give this process its own POCL_CACHE_DIR (a child does not reuse its parent's)."""
    if os.environ.get(_PID_VAR) == str(os.getpid()):
        return
    folder = tempfile.mkdtemp(prefix="mmocap-pocl-")
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    os.environ["POCL_CACHE_DIR"] = folder
    os.environ[_PID_VAR] = str(os.getpid())


def _pin_pocl_threads() -> None:
    """Ask PoCL to pin its worker threads to one core each (``POCL_AFFINITY=1``) unless the
    environment says otherwise: CMA-ES frames take longer with the threads free to move."""
    os.environ.setdefault("POCL_AFFINITY", "1")


def pyopencl():
    """The pyopencl module, imported on first use after the PoCL variables are set; a
    ConfigError that says what to install when it cannot be imported."""
    global _cl
    if _cl is None:
        _private_pocl_cache()
        _pin_pocl_threads()
        try:
            import pyopencl as cl
        except (ImportError, OSError) as err:
            raise ConfigError(
                f"pyopencl cannot be imported ({err}); install with: {INSTALL}; or choose evaluator=numpy"
            ) from None
        _cl = cl
    return _cl


def unavailable() -> str | None:
    """Why no OpenCL device can be used in this process (one line, with what to install),
    or None when a platform with a device exists."""
    try:
        select_platform(None)
    except ConfigError as err:
        return str(err)
    return None


def platforms() -> list:
    """The OpenCL platforms; ConfigError when there is none."""
    cl = pyopencl()
    try:
        found = cl.get_platforms()
    except cl.Error as err:
        found, reason = [], str(err)
    else:
        reason = "the ICD loader lists none"
    if not found:
        raise ConfigError(
            f"no OpenCL platform found ({reason}); install with: pip install "
            "pocl-binary-distribution (a CPU platform), or a GPU's OpenCL driver; "
            "or choose evaluator=numpy"
        )
    return found


def describe(found) -> str:
    """'[0] PoCL: [0] cpu-name, ...' for an error message."""
    return "; ".join(
        f"[{i}] {p.name}: " + ", ".join(f"[{k}] {d.name.strip()}" for k, d in enumerate(p.get_devices()))
        for i, p in enumerate(found)
    )


def select_platform(platform):
    """A platform by index, by part of its name, or (None) the first that has a GPU, else the
    first with any device (PoCL's CPU), never one of the :data:`SIMULATORS`: on a machine with a
    GPU driver beside PoCL the GPU runs whatever order the ICD loader lists them in."""
    found = platforms()
    if platform is None:
        real = [p for p in found if p.get_devices() and not any(name in p.name.lower() for name in SIMULATORS)]
        gpu = pyopencl().device_type.GPU
        with_gpu = [p for p in real if any(d.type & gpu for d in p.get_devices())]
        if with_gpu or real:
            return (with_gpu or real)[0]
        raise ConfigError(
            f"no OpenCL platform has a device ({describe(found)}); install with: "
            "pip install pocl-binary-distribution (a CPU platform), or a GPU's "
            "OpenCL driver; or choose evaluator=numpy"
        )
    if isinstance(platform, (int, np.integer)) and not isinstance(platform, bool):
        if 0 <= platform < len(found):
            return found[platform]
        raise ConfigError(f"OpenCL platform index {platform} does not exist; there are {len(found)}: {describe(found)}")
    if isinstance(platform, str):
        match = [p for p in found if platform.lower() in p.name.lower()]
        if match:
            return match[0]
    raise ConfigError(f"no OpenCL platform matches platform={platform!r}; there are: {describe(found)}")


def select_device(platform, device):
    """One device of a platform (see :func:`select_platform`) by index."""
    p = select_platform(platform)
    devices = p.get_devices()
    if isinstance(device, bool) or not isinstance(device, (int, np.integer)):
        raise ConfigError(f"OpenCL device must be an index, got {device!r}")
    if not 0 <= device < len(devices):
        raise ConfigError(
            f"OpenCL device index {device} does not exist on platform "
            f"{p.name!r}, which has {len(devices)}: {describe([p])}"
        )
    return devices[device]


def context(devices):
    """The process's one ``pyopencl.Context`` for this tuple of devices."""
    key = tuple(d.int_ptr for d in devices)
    if key not in _CONTEXTS:
        _CONTEXTS[key] = pyopencl().Context(list(devices))
    return _CONTEXTS[key]


def kernel_source() -> str:
    """The text of ``kernels/silhouette.cl``, package data of :mod:`mmocap.evaluators`."""
    return (resources.files("mmocap.evaluators") / "kernels" / "silhouette.cl").read_text()


def program(ctx, options: list[str]):
    """The kernel built for a context with these build options (see
    :func:`mmocap.evaluators.opencl_layout.build_options`), once per process."""
    key = (ctx.int_ptr, tuple(options))
    if key not in _PROGRAMS:
        _PROGRAMS[key] = pyopencl().Program(ctx, kernel_source()).build(options=list(options))
    return _PROGRAMS[key]


def compiled_vector_bits(ctx, device) -> int:
    """The width in bits of the float vector registers that the device's kernel compiler
    targets (x86: 512 with AVX-512, 256 with AVX, 128 with SSE), 0 where it does not say;
    once per process and device. It may be less than the device reports: PoCL 3.0 compiles
    for the CPU that LLVM 14 names, and a Zen 4 is an AVX2 CPU to it."""
    if device.int_ptr not in _VECTOR_BITS:
        cl = pyopencl()
        probe = cl.Program(ctx, _VECTOR_BITS_PROBE).build(devices=[device])
        queue = cl.CommandQueue(ctx, device)
        out = np.zeros(1, np.int32)
        written = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, out.nbytes)
        probe.vector_bits(queue, (1,), None, written)
        cl.enqueue_copy(queue, out, written)
        _VECTOR_BITS[device.int_ptr] = int(out[0])
    return _VECTOR_BITS[device.int_ptr]


def sub_devices(device, count: int) -> list:
    """``count`` sub-devices of equal compute units of a device (cached per process)."""
    key = (device.int_ptr, count)
    if key not in _SUB_DEVICES:
        units = device.max_compute_units
        if not 1 <= count <= units:
            raise ConfigError(
                f"cannot split OpenCL device {device.name.strip()!r} with {units} "
                f"compute units into {count} sub-devices"
            )
        partition = pyopencl().device_partition_property.EQUALLY
        _SUB_DEVICES[key] = device.create_sub_devices([partition, units // count])[:count]
    return _SUB_DEVICES[key]
