"""What the keypoint term costs: the time per evaluation of a backend with the hybrid fitness
(:mod:`mmocap.evaluators.keypoint_term`: the 17 model points, weight > 0) against the
silhouettes alone, and their ratio (goal: at most :data:`GOAL_RATIO`).

Workloads (``--workloads``): the demo's (4 cameras, 13 695 vertices) and Cano's benchmark's
(7 cameras, 27 393 vertices), 640x480, on the synthetic benchmark scene
(:class:`~mmocap.testing.scene.Scene`), with keypoints where its reference pose puts the
model points (:func:`scene_keypoints`). Each is timed at two populations: the holistic
CMA-ES's (lambda for the body's active degrees of freedom: what one call of the tracker
evaluates) and Table 2's (``--population``), each with ``repeats`` x :data:`CANDIDATES`
candidates off and as many on, in calls of the population. The evaluator is set up once,
with the keypoints; off is what its call computes without them, the silhouettes' fitness
from its :meth:`~mmocap.evaluators.silhouette.SilhouetteEvaluator.counts`, and on its call.
Off and on take turns call by call, so that a load that changes meanwhile affects both
alike, and the best call of each is kept (where other processes share the cores, a call is
slowed by whatever ran meanwhile, and the best of many comes nearest an undisturbed one).
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from mmocap.body.keypoints import MODEL_POINTS, model_points
from mmocap.body.model import VERTICES_RANGE
from mmocap.data.synthetic import CAMERA_RING
from mmocap.errors import ConfigError
from mmocap.evaluators.keypoint_term import Keypoints, KeypointTerm
from mmocap.evaluators.silhouette import PATCH_SCALE, fitness_from_counts, keypoint_pixels, view_geometry
from mmocap.optimizers.cmaes import strategy_parameters
from mmocap.testing.scene import Scene
from mmocap.validate import check_number

#: the default ``--workloads``, CAMERAS:VERTICES: the demo's and Cano's benchmark's
WORKLOADS = "4:13695,7:27393"
#: the issue's goal: the term costs at most 10 % more per evaluation
GOAL_RATIO = 1.10
#: the term's weight while timed (any weight > 0 costs the same)
WEIGHT = 1.0
#: candidates evaluated per repeat, off and on each
CANDIDATES = 1024


def parse_workloads(text: str) -> list[tuple[int, int]]:
    """``"4:13695,7:27393"`` -> [(cameras, vertices), ...], cameras of the synthetic ring and
    a vertex level of the body; a ConfigError naming ``--workloads`` otherwise."""
    workloads = []
    for item in text.split(","):
        try:
            cameras, vertices = (int(v) for v in item.split(":"))
        except ValueError:
            raise ConfigError(f"--workloads must be CAMERAS:VERTICES[,...] such as {WORKLOADS}, got {text!r}") from None
        check_number("--workloads cameras", cameras, 1, len(CAMERA_RING), integer=True)
        check_number("--workloads vertices", vertices, *VERTICES_RANGE, integer=True)
        workloads.append((cameras, vertices))
    return workloads


def scene_keypoints(scene: Scene, weight: float = WEIGHT) -> Keypoints:
    """The 17 model points (:data:`~mmocap.body.keypoints.MODEL_POINTS`) where the scene's
    reference pose puts them in each of its cameras, seen with confidence 1 (NaN and
    confidence 0 behind a camera), with the keypoint term of ``weight``."""
    joint, rest = model_points(scene.body, MODEL_POINTS)
    coefficients, _ = view_geometry(scene.body, scene.cameras, scene.pose[None], PATCH_SCALE)
    pixels = keypoint_pixels(coefficients, joint, rest)[0].astype(np.float64)  # (C, K, 2)
    seen = np.isfinite(pixels[..., :1]).astype(np.float64)
    observed = np.concatenate([pixels, seen], axis=2)
    return Keypoints(MODEL_POINTS, np.zeros((len(MODEL_POINTS), 3)), observed, KeypointTerm(weight=weight))


def silhouette_fitness(ev, X: np.ndarray) -> np.ndarray:
    """What ``ev`` set up without keypoints returns for the poses ``X`` (n, P): the (n,)
    silhouettes' fitness from its counts."""
    model_px, overlap_px = ev.counts(X)
    return fitness_from_counts(model_px, overlap_px, ev.fg_px)


def evaluation_us(ev, scene: Scene, keypoints: Keypoints, X: np.ndarray, calls: int) -> tuple[float, float]:
    """Best time per evaluation in microseconds of ``ev``, set up with ``keypoints``, on the
    poses ``X`` (n, P) without the keypoint term (the silhouettes' fitness from its counts)
    and with it (its call), ``calls`` calls each in turn after a warm-up."""
    ev.setup(scene.body, scene.cameras, scene.foreground, keypoints)
    ways = {
        "off": lambda: silhouette_fitness(ev, X),
        "on": lambda: ev(X),
    }
    best = dict.fromkeys(ways, np.inf)
    for evaluate in ways.values():  # warm-up: kernels, caches, workers, buffers
        evaluate()
    for _ in range(calls):
        for way, evaluate in ways.items():
            start = time.perf_counter()
            evaluate()
            best[way] = min(best[way], time.perf_counter() - start)
    return best["off"] / len(X) * 1e6, best["on"] / len(X) * 1e6


def keypoint_table(
    evaluators: dict, workloads: list[tuple[int, int]], population: int, repeats: int, candidates: int = CANDIDATES
) -> pd.DataFrame:
    """Per backend, workload (cameras, vertices) and population (the holistic CMA-ES's and
    ``population``, each in calls that evaluate ``repeats`` x ``candidates`` candidates):
    microseconds per evaluation with the keypoint term off and on, and their ratio."""
    rows = []
    for cameras, vertices in workloads:
        scene = Scene(vertices, cameras)
        keypoints = scene_keypoints(scene)
        cmaes = strategy_parameters(int(np.count_nonzero(scene.body.mask))).lam
        for name, ev in evaluators.items():
            for n in dict.fromkeys((cmaes, population)):
                calls = repeats * -(-candidates // n)
                off, on = evaluation_us(ev, scene, keypoints, scene.candidates(n), calls)
                rows.append(
                    {
                        "backend": name,
                        "cameras": cameras,
                        "vertices": vertices,
                        "population": n,
                        "us_per_evaluation_off": off,
                        "us_per_evaluation_on": on,
                        "ratio_on_to_off": on / off,
                    }
                )
                print(
                    f"keypoints: {cameras} cameras, {vertices} vertices, {name}, population {n}: "
                    f"{off:.1f} us per evaluation off, {on:.1f} on ({on / off:.3f}x)",
                    flush=True,
                )
    return pd.DataFrame(rows)
