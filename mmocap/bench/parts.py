"""Where the silhouette kernel's time goes (``mmocap bench parts``, and beside the roofline):
the kernel built to stop after each of its :data:`PARTS` in turn (``-DPARTS=k`` keeps the
first k; ``kernels/silhouette.cl``), each timed as Table 2 times the whole kernel, in
rounds that time every build once, best round kept per build. A part's cost is the
difference between the builds that stop after it and before it.

The parts are those of a view that takes the layered path (every 640x480 view of the
benchmark scene does): the stamp path for large patches and the bands are not split. A
build that stops early keeps what it computed alive with one vector operation per vector
of vertices (else the compiler would drop the work), and counts nothing: its counts are
meaningless.
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from mmocap.testing.scene import Scene

#: the kernel's parts in the order it runs them, by their ``PART_*`` name in the kernel
PARTS = {
    "CALL": "call, launch, read-back and the joint transforms",
    "SETUP": "per-view setup: patch sides, clearing the layers, per-joint coefficients",
    "CULLING": "block tests and per-vertex back-face culling",
    "PROJECTION": "projection (u, v and the correctly rounded division)",
    "CENTRES": "centre pixels, their bounding box and bit addresses",
    "ORS": "ORs into the layers",
    "COUNT": "dilation and count against the foreground",
}


def part_options(kept: int) -> list[str]:
    """The build options of a kernel that keeps the first ``kept`` parts of :data:`PARTS`
    (all of them: the whole kernel, which counts what it should)."""
    names = [f"-DPART_{name}={k}" for k, name in enumerate(PARTS, start=1)]
    return names if kept == len(PARTS) else [f"-DPARTS={kept}", *names]


def parts_table(make_evaluator, scene: Scene, population: int, rounds: int) -> pd.DataFrame:
    """Microseconds per model-view of the kernel stopped after each part (``until_us``) and
    each part's own (``part_us``, the difference; noise may make a small one negative) and
    share of the whole kernel, ``population`` candidates in camera 0 of ``scene`` per call;
    ``make_evaluator()`` gives a new OpenCL evaluator."""
    evaluators = []
    X = scene.candidates(population)
    try:
        for kept in range(1, len(PARTS) + 1):
            ev = make_evaluator()
            evaluators.append(ev)
            ev.build_with(part_options(kept))
            ev.setup(scene.body, scene.cameras[:1], scene.foreground[:1])
            ev(X)  # warm-up: build, caches
        best = np.full(len(PARTS), np.inf)
        for _ in range(rounds):
            for k, ev in enumerate(evaluators):
                start = time.perf_counter()
                ev(X)
                best[k] = min(best[k], time.perf_counter() - start)
    finally:
        for ev in evaluators:
            ev.close()
    until = best / population * 1e6
    part = np.diff(until, prepend=0.0)
    return pd.DataFrame({"part": list(PARTS.values()), "until_us": until, "part_us": part, "share": part / until[-1]})
