"""The silhouette kernel's roofline on an OpenCL device: what one model-view needs of each
resource, what the device does of each (measured by ``kernels/roofline.cl``), and the floor
in microseconds per model-view that follows.

What one model-view needs, at ``vertices`` skin samples and a ``width`` x ``height`` view,
counted from ``kernels/silhouette.cl`` as the least any kernel that projects vertices into a
bit mask does, even one that skipped the back faces (about half of a closed surface's
vertices, :data:`FACING`) at no cost:

- ``arithmetic``: :data:`FLOPS_PER_VERTEX` float32 operations per facing vertex (the depth,
  both image coordinates and the division of the projection);
- ``reads``: its position, :data:`BYTES_PER_VERTEX` bytes, from an array every model-view
  shares (cache-resident, as the device sees it);
- ``scatter``: one OR into the mask per facing vertex, plus clearing a ``width`` x ``height``
  bit mask.

Each resource's time is its need over the measured rate; the floor is the largest of them
(a roofline: an out-of-order core overlaps the others with it). The kernel also reads the
normals of the blocks it cannot cull whole, tests them, counts the mask against the
foreground and does per-view and per-joint work in float64; all that is left out, so the
floor is a lower bound.

The rates are measured with every compute unit busy (:data:`GROUPS` work-groups of one
work-item, as the silhouette kernel runs on CPUs), best of ``repeats`` timings.
:func:`table` puts the kernel's own time per model-view (Cano Table 2) beside the floor.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from importlib import resources

import numpy as np
import pandas as pd

from mmocap.evaluators.opencl_devices import context, pyopencl, select_platform

#: float32 operations per facing vertex: the projection (depth 6, u and v 7 each, the
#: division 1)
FLOPS_PER_VERTEX = 21
#: bytes read per facing vertex: its position (3 float32)
BYTES_PER_VERTEX = 12
#: share of a closed surface's vertices that face a camera
FACING = 0.5
#: work-groups per microbenchmark call: many per compute unit
GROUPS = 256
#: float32 lanes per vector of the arithmetic benchmark (float16 in ``kernels/roofline.cl``)
ARITHMETIC_LANES = 16
#: words of local memory the scatter benchmark clears and ORs into: 16 KB (a power of two), which
#: the first-level cache holds, for the best rate (a floor takes the best)
SCATTER_WORDS = 4096


@dataclass(frozen=True)
class Rates:
    """What a device does per second with every compute unit busy: float32 operations
    (``flops``), bytes read from a cache-resident global array (``read_bytes``), words of
    local memory cleared (``clear_words``) and scattered single-bit ORs into local memory
    (``ors``)."""

    flops: float
    read_bytes: float
    clear_words: float
    ors: float


def _best_seconds(queue, launch, repeats: int) -> float:
    """Best wall time of ``launch()`` (which enqueues kernels) to the end of its work."""
    launch()
    queue.finish()  # warm-up: compilation, caches
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        launch()
        queue.finish()
        best = min(best, time.perf_counter() - start)
    return best


def measure(platform=None, array_bytes: int = 768 * 1024, repeats: int = 10) -> tuple[Rates, str]:
    """The :class:`Rates` of the first device of ``platform`` (as for ``evaluator=opencl``)
    and the device's name. ``array_bytes``: size of the array every work-group reads (the
    vertex array of the 27393-vertex body is 767 KB)."""
    cl = pyopencl()
    device = select_platform(platform).get_devices()[0]
    ctx = context((device,))
    queue = cl.CommandQueue(ctx, device)
    source = (resources.files("mmocap.bench") / "kernels" / "roofline.cl").read_text()
    program = cl.Program(ctx, source).build()
    arithmetic, reads, scatter = (cl.Kernel(program, name) for name in ("arithmetic", "reads", "scatter"))
    out = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, 4 * GROUPS)

    def seconds(kernel, *args) -> float:
        kernel.set_args(*args, out)
        return _best_seconds(queue, lambda: cl.enqueue_nd_range_kernel(queue, kernel, (GROUPS,), (1,)), repeats)

    iterations = 4096
    arithmetic_s = seconds(arithmetic, np.int32(iterations), np.float32(0.999), np.float32(1e-3))
    n8 = max(4, array_bytes // 32 // 4 * 4)
    data = cl.Buffer(ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=np.ones(8 * n8, np.float32))
    reads_s = seconds(reads, data, np.int32(n8))
    local, ors = cl.LocalMemory(4 * SCATTER_WORDS), 64 * SCATTER_WORDS
    clear_s = seconds(scatter, np.int32(SCATTER_WORDS), np.int32(0), local)
    scatter_s = seconds(scatter, np.int32(SCATTER_WORDS), np.int32(ors), local)
    return Rates(
        flops=GROUPS * iterations * 2 * 8 * ARITHMETIC_LANES / arithmetic_s,
        read_bytes=GROUPS * 32 * n8 / reads_s,
        clear_words=GROUPS * SCATTER_WORDS / clear_s,
        ors=GROUPS * ors / max(scatter_s - clear_s, 1e-9),
    ), device.name.strip()


def needs(vertices: int, width: int, height: int) -> dict[str, float]:
    """What one model-view needs at least (see the module docstring): ``flops``, ``bytes``
    read, local ``ors`` (one per facing vertex) and mask ``words`` cleared."""
    facing = round(FACING * vertices)
    return {
        "flops": FLOPS_PER_VERTEX * facing,
        "bytes": BYTES_PER_VERTEX * facing,
        "ors": facing,
        "words": (width + 31) // 32 * height,
    }


def floor_us(rates: Rates, vertices: int, width: int, height: int) -> dict[str, float]:
    """Microseconds per model-view that each resource needs at these rates (``arithmetic``,
    ``reads``, ``scatter``), and ``floor``, the largest of them (see the module docstring)."""
    need = needs(vertices, width, height)
    us = {
        "arithmetic": need["flops"] / rates.flops,
        "reads": need["bytes"] / rates.read_bytes,
        "scatter": need["ors"] / rates.ors + need["words"] / rates.clear_words,
    }
    us = {name: seconds * 1e6 for name, seconds in us.items()}
    return {**us, "floor": max(us.values())}


def table(vertices: int, kernel_us: float) -> pd.DataFrame:
    """The silhouette kernel's roofline on the default OpenCL device at ``vertices`` and
    640x480: per resource what a model-view needs, the measured rate and the microseconds
    that follow; the floor (the largest); and the kernel as measured (``kernel_us``, Table
    2), each with its ratio to the floor."""
    rates, device = measure()
    us, need = floor_us(rates, vertices, 640, 480), needs(vertices, 640, 480)
    rows = [
        {
            "resource": "float32 arithmetic",
            "need_per_model_view": f"{need['flops']} flop",
            "measured_rate": f"{rates.flops / 1e9:.1f} Gflop/s",
            "us_per_model_view": us["arithmetic"],
        },
        {
            "resource": "reads (cache-resident)",
            "need_per_model_view": f"{need['bytes'] / 1e3:.0f} kB",
            "measured_rate": f"{rates.read_bytes / 1e9:.1f} GB/s",
            "us_per_model_view": us["reads"],
        },
        {
            "resource": "local memory: clear, scattered ORs",
            "need_per_model_view": f"{need['words']} words, {need['ors']} ORs",
            "measured_rate": f"{rates.clear_words / 1e9:.2f} Gword/s, {rates.ors / 1e9:.2f} GOR/s",
            "us_per_model_view": us["scatter"],
        },
        {
            "resource": "floor (the largest)",
            "need_per_model_view": "",
            "measured_rate": "",
            "us_per_model_view": us["floor"],
        },
        {
            "resource": "silhouette kernel (Table 2)",
            "need_per_model_view": "",
            "measured_rate": "",
            "us_per_model_view": kernel_us,
        },
    ]
    df = pd.DataFrame(rows)
    df["ratio_to_floor"] = df.us_per_model_view / us["floor"]
    print(f"roofline: {device}: floor {us['floor']:.1f} us, kernel {kernel_us:.1f} us per model-view", flush=True)
    return df
