"""Interfaces shared by the stages: optimisers, evaluators and the search space.

Optimisers and evaluators are found through the entry-point groups
``mmocap.optimizers`` and ``mmocap.evaluators`` (see :mod:`mmocap.registry`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, Self, runtime_checkable

import numpy as np


@dataclass(frozen=True)
class SearchSpace:
    """A box around a start point in which one frame (or one partition) is searched.

    Attributes:
        x0: (D,) start point, usually the previous frame's estimate.
        lower, upper: (D,) bounds, lower < upper element-wise.
        radius: (D,) search radius per coordinate in its own units (rad, mm): the unit
            of the optimisers' normalised coordinates and the scale of their first step.
        budget: maximum number of fitness evaluations for this search.
        partitions: optional groups of coordinate indices (each an int array into the D
            coordinates, together covering each coordinate once) in hierarchical order,
            e.g. root first, then torso, then each limb.  Partitioned-sampling optimisers
            (PSAPF) search them one after another; the others ignore them.  None means
            one partition holding every coordinate.
    """

    x0: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    radius: np.ndarray
    budget: int
    partitions: tuple[np.ndarray, ...] | None = None

    @property
    def dim(self) -> int:
        """D, the number of searched coordinates."""
        return int(self.x0.shape[0])


@dataclass
class Result:
    """Best point found so far."""

    xbest: np.ndarray
    fbest: float
    evaluations: int
    iterations: int
    stop_reasons: dict[str, float] = field(default_factory=dict)


@runtime_checkable
class Optimizer(Protocol):
    """Batch ask/tell minimiser.

    ``setup`` starts a new search; then ``ask`` returns a whole population (n, D) that lies
    inside the bounds and never makes the evaluation count exceed ``space.budget``;
    ``tell`` takes the fitness (n,) of exactly what ``ask`` returned; ``stop`` returns
    ``{}`` to go on or a dict of reasons.
    """

    def setup(self, space: SearchSpace, rng: np.random.Generator) -> None:
        """Start a new search in ``space``; every random number comes from ``rng``."""

    def ask(self) -> np.ndarray:
        """The next population, (n, D) in the original units, inside the bounds."""

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        """Take the fitness ``f`` (n,) of exactly the population ``X`` (n, D) that :meth:`ask`
        returned."""

    def stop(self) -> dict[str, float]:
        """``{}`` to go on, else the reasons to stop, each with its value (``budget``: the
        evaluations used)."""

    @property
    def result(self) -> Result:
        """The best point found so far."""


@runtime_checkable
class Evaluator(Protocol):
    """Silhouette fitness of candidate poses (Yeguas Eq. 4-5): everything callers use.

    :class:`mmocap.evaluators.silhouette.SilhouetteEvaluator` implements it and specifies
    the rule that every backend computes; the conformance suite
    (:mod:`mmocap.testing.evaluators`) holds a backend to it. Lifecycle: built from its
    config parameters (``patch_scale`` and its own), then per frame :meth:`setup`, then any
    number of :meth:`__call__`, :meth:`counts` and :meth:`render`; :meth:`close` releases
    the frame's data and what the backend holds (worker processes, device buffers), after
    which :meth:`setup` may be called again. As a context manager it closes on exit.

    Shapes and units (n candidates, C cameras, P pose parameters, J joints, N vertices):

    - ``body``: ``rest_vertices`` (N, 3) mm, ``rest_normals`` (N, 3) unit,
      ``vertex_joint`` (N,) int, ``joint_rest_positions`` (J, 3) mm, ``patch_mm`` (J,) mm
      and ``transforms(X)``: (n, P) -> (n, J, 4, 4) rigid rest-to-world transforms (mm).
    - ``cameras``: C cameras (``K`` in px, ``R``, ``t`` in mm, ``width`` x ``height`` px).
    - ``foreground``: C bool-like masks, (H_c, W_c) each, True on the person.
    - ``X``: (n, P) float64 poses in the body's full parameter vector (root translation in
      mm, angles in rad); NaN is an error naming the row; n may be 0.

    Attributes:
        name: entry-point name of the backend that computes (``evaluator=auto`` reports
            its choice, e.g. ``"opencl"``); empty for a class that does not say.
        owns_cores: True while its own threads or workers keep every CPU core busy during
            a call (then BLAS in this process runs on one thread from setup to close).
        starts_processes: True for a backend that starts worker processes of its own (it
            cannot run inside a launcher's daemon workers; the sweep checks this).
    """

    @property
    def name(self) -> str: ...

    @property
    def owns_cores(self) -> bool: ...

    @property
    def starts_processes(self) -> bool: ...

    def setup(self, body: Any, cameras: Sequence[Any], foreground: Sequence[np.ndarray], keypoints: Any = None) -> None:
        """Upload one frame: the body, C cameras, their C foreground masks and optionally
        their 2-D keypoints (:class:`~mmocap.evaluators.keypoint_term.Keypoints`), which add
        the keypoint term to the fitness."""

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """(n, P) poses -> (n,) float64 fitness, 0 a perfect match: the silhouettes' in [0, 1]
        (Cano Eq. 6-7: the mean over the cameras of the per-view terms), plus the weighted
        keypoint term when :meth:`setup` was given keypoints; never NaN."""

    def silhouette_fitness(self, X: np.ndarray) -> np.ndarray:
        """(n, P) poses -> (n,) float64 the silhouettes' fitness alone, in [0, 1]."""

    def counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n, P) poses -> ``model_px`` ``|M_c|`` and ``overlap_px`` ``|M_c & F_c|``, each
        (n, C) int64 pixels, equal for every backend."""

    def render(self, x: np.ndarray, camera_index: int) -> np.ndarray:
        """(P,) pose -> (H_c, W_c) bool model silhouette ``M_c`` in camera ``camera_index``."""

    def close(self) -> None:
        """Release the frame's data and the backend's workers or buffers; idempotent."""

    def __enter__(self) -> Self: ...

    def __exit__(self, *exc: object) -> None:
        """Close."""


@runtime_checkable
class Detector(Protocol):
    """A 2-D keypoint detector (``keypoints.source=detector``, ``keypoints.detector=<name>``).

    Attributes:
        skeleton: the name of the skeleton it finds, one of
            :data:`mmocap.data.skeletons.SKELETONS` (its joints' order is the rows').
    """

    @property
    def skeleton(self) -> str: ...

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """(H, W, 3) BGR or (H, W) grey 8-bit image, as the camera recorded it (with its
        lens distortion) -> (J, 3) float: ``u, v`` px in that image and the confidence in
        [0, 1] per joint of the skeleton; all 0 for a joint (or a person) not found."""
