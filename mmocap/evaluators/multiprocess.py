"""Population-parallel evaluator: the population split over a persistent pool of processes.

Each worker holds its own single-process backend (``inner``, ``numpy`` by default) and
evaluates a contiguous slice of the candidates; the counts are therefore exactly the inner
backend's. Per frame, :meth:`MultiprocessingEvaluator.setup` writes the foreground masks
once into a file in shared memory (``/dev/shm`` where it exists) that every worker maps
read-only, and sends the cameras (and the body, only when it is a different object from
the last frame's); per call only the poses travel, (n/workers, P) float64 each way.

Workers are started with ``spawn`` on the first :meth:`setup` (about a second) and live
until :meth:`close`; BLAS in the workers is limited to one thread, so that ``workers``
processes use ``workers`` cores.
"""

from __future__ import annotations

import multiprocessing
import os
import tempfile
from contextlib import contextmanager, suppress

import numpy as np

from mmocap import registry
from mmocap.errors import ConfigError
from mmocap.evaluators.silhouette import PATCH_SCALE, SilhouetteEvaluator

_ONE_THREAD = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


class MultiprocessingEvaluator(SilhouetteEvaluator):
    """The silhouette fitness with the population split over ``workers`` processes.

    Args:
        patch_scale: factor on the body's per-joint patch size (Cano Eq. 4), > 0.
        workers: number of worker processes (None: the number of CPUs), >= 1.
        inner: entry-point name of the backend each worker runs (not ``multiprocessing``).
    """

    name = "multiprocessing"
    owns_cores = True
    starts_processes = True

    def __init__(self, patch_scale: float = PATCH_SCALE, workers: int | None = None, inner: str = "numpy"):
        super().__init__(patch_scale)
        if workers is None:
            workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
        if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
            raise ConfigError(f"workers must be an integer >= 1, got {workers!r}")
        available = registry.available("evaluator")
        if inner == "multiprocessing" or inner not in available:
            raise ConfigError(
                f"inner must be a single-process evaluator, one of "
                f"{', '.join(n for n in sorted(available) if n != 'multiprocessing')}; "
                f"got {inner!r}"
            )
        self.workers, self.inner = int(workers), inner
        self._pool: list = []
        self._sent_body = None
        self._shared: str | None = None

    def _prepare(self) -> None:
        if not self._pool:
            self._start()
        self._release_shared()
        folder = "/dev/shm" if os.path.isdir("/dev/shm") else None
        fd, self._shared = tempfile.mkstemp(prefix="mmocap-fg-", suffix=".npy", dir=folder)
        os.close(fd)
        np.save(self._shared, np.concatenate([m.ravel() for m in self.foreground]))
        body = self.body if self.body is not self._sent_body else None
        self._ask_all([("setup", body, self.cameras, self._shared)] * len(self._pool))
        self._sent_body = self.body

    def _start(self) -> None:
        ctx = multiprocessing.get_context("spawn")
        with _env(**{name: "1" for name in _ONE_THREAD}):
            for _ in range(self.workers):
                parent, child = ctx.Pipe()
                proc = ctx.Process(target=_serve, args=(child, self.inner, self.patch_scale), daemon=True)
                proc.start()
                child.close()
                self._pool.append((proc, parent))

    def _ask_all(self, messages: list) -> list:
        """Send one message per worker (the first len(messages) workers), gather replies."""
        for (_, conn), message in zip(self._pool, messages):
            conn.send(message)
        replies = []
        for (proc, conn), _ in zip(self._pool, messages):
            try:
                status, value = conn.recv()
            except EOFError:
                raise RuntimeError(f"evaluator worker {proc.pid} died (exit code {proc.exitcode})") from None
            if status == "error":
                raise RuntimeError(f"evaluator worker {proc.pid}: {value}")
            replies.append(value)
        return replies

    def _counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        chunks = [c for c in np.array_split(X, min(len(self._pool), len(X))) if len(c)]
        replies = self._ask_all([("counts", c) for c in chunks])
        return (np.concatenate([r[0] for r in replies]), np.concatenate([r[1] for r in replies]))

    def _render(self, x: np.ndarray, camera_index: int) -> np.ndarray:
        return self._ask_all([("render", x, camera_index)])[0]

    def _release_shared(self) -> None:
        if self._shared is not None:
            os.unlink(self._shared)
            self._shared = None

    def close(self) -> None:
        """Stop the workers and remove the shared frame data."""
        for _, conn in self._pool:
            with suppress(BrokenPipeError, OSError):
                conn.send(None)
        for proc, conn in self._pool:
            proc.join(timeout=5)
            if proc.is_alive():
                proc.terminate()
            conn.close()
        self._pool, self._sent_body = [], None
        self._release_shared()
        super().close()

    def __del__(self):
        if getattr(self, "_pool", None):
            self.close()


@contextmanager
def _env(**values: str):
    """Set environment variables for the duration of the block (spawned children copy them)."""
    saved = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _serve(conn, inner: str, patch_scale: float) -> None:
    """Worker loop: ('setup', body or None, cameras, path), ('counts', X), ('render', x, c);
    None ends it. Replies ('ok', value) or ('error', message)."""
    evaluator = registry.make_evaluator(inner, patch_scale=patch_scale)
    body = None
    while (message := conn.recv()) is not None:
        try:
            if message[0] == "setup":
                _, new_body, cameras, path = message
                body = new_body if new_body is not None else body
                pixels = np.load(path, mmap_mode="r")
                masks, start = [], 0
                for cam in cameras:
                    size = cam.height * cam.width
                    masks.append(pixels[start : start + size].reshape(cam.height, cam.width))
                    start += size
                evaluator.setup(body, cameras, masks)
                reply: object = None
            elif message[0] == "counts":
                reply = evaluator.counts(message[1])
            else:
                reply = evaluator.render(message[1], message[2])
            conn.send(("ok", reply))
        except Exception as err:  # reported to the parent, which raises it
            conn.send(("error", f"{type(err).__name__}: {err}"))
    evaluator.close()
