"""Golden results: what must not change at a fixed seed.

- the exact pixel counts |M| and |M & F| (integers, by the fitness rule) of six fixed poses
  of the 2000-vertex body in three 640x480 views, for every evaluator that runs here;
- for every built-in optimiser (the ``mmocap.optimizers`` entry points of the mmocap
  distribution itself, found through :mod:`mmocap.registry`; plugins installed beside it,
  such as mmocap-pycma or the template's ``changeme``, are not golden here and need no
  data): its first proposals, and its best point and value after :data:`GENERATIONS`
  generations on a fixed 12-D ellipsoid (:func:`objective`);
- the SHA-256 of every candidate that CMA-ES asks in 12 searches (both bound handlings,
  three tracking-like functions at 39 DOF, two seeds each): bit for bit the same numbers, so
  a refactor that keeps it is exact.

A change that moves them on purpose regenerates the files with ``make golden``
(``MMOCAP_REGEN_GOLDEN=1 pytest tests/golden``); the diff of ``tests/golden/data/`` then
shows what moved. First proposals come from the generator alone and are compared to 1e-12;
later generations go through BLAS (CMA-ES's sampling and eigendecompositions), whose last
bits may differ from one CPU kernel to another, so trajectories are compared to 1e-9 and the
candidate hash, which is exact on purpose, holds for the BLAS it was recorded with. Tracked
poses over many frames are not golden (see ``tests/test_pipeline.py``, which checks them
statistically).
"""

import hashlib
import json
import os
from importlib.metadata import entry_points
from pathlib import Path

import numpy as np
import pytest

from mmocap import registry
from mmocap.api import SearchSpace
from mmocap.testing.objectives import SHIFT, TRACKING_LIKE, box, ellipsoid_1e3
from mmocap.testing.scene import Scene

DATA = Path(__file__).with_name("data")
REGENERATE = os.environ.get("MMOCAP_REGEN_GOLDEN") == "1"
EVALUATORS = ["numpy", "naive", "opencl"]  # numpy first: it writes the file when regenerating
#: the built-in optimisers: mmocap's own entry points, not those of installed plugins
OPTIMIZERS = sorted(
    ep.name
    for ep in entry_points(group=registry.GROUPS["optimizer"])
    if ep.dist is not None and ep.dist.name == "mmocap"
)
#: ask/tell rounds of each optimiser's recorded trajectory
GENERATIONS = 5
DIM = 12


def golden(name: str, value):
    """The stored value of ``name`` (``value`` written instead when regenerating)."""
    path = DATA / f"{name}.json"
    if REGENERATE:
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps(value, indent=1) + "\n")
    if not path.is_file():
        pytest.fail(f"no golden data {path}: run `make golden` and review the new file")
    return json.loads(path.read_text())


def space() -> SearchSpace:
    """12 coordinates in three partitions, an uneven start inside the box [-1, 1]."""
    return SearchSpace(
        x0=np.linspace(-0.2, 0.3, DIM),
        lower=np.full(DIM, -1.0),
        upper=np.full(DIM, 1.0),
        radius=np.full(DIM, 0.5),
        budget=600,
        partitions=(np.arange(0, 3), np.arange(3, 7), np.arange(7, 12)),
    )


def objective(X: np.ndarray) -> np.ndarray:
    """The ellipsoid of condition 1e3 with its optimum at ``SHIFT[:12]``: (n, 12) -> (n,)."""
    return ellipsoid_1e3(X - SHIFT[:DIM])


def test_the_builtin_optimisers_are_found_through_the_registry():
    assert {"cmaes", "de", "pso", "apf", "psapf"} <= set(OPTIMIZERS)
    assert set(OPTIMIZERS) <= set(registry.available("optimizer"))


@pytest.fixture(scope="module")
def scene():
    return Scene(vertices=2000, cameras=3, seed=0)


@pytest.mark.parametrize("name", EVALUATORS)
def test_pixel_counts_of_fixed_poses(scene, name):
    reason = registry.unavailable("evaluator", name)
    if reason:
        pytest.skip(reason)
    X = scene.candidates(6, seed=3)
    with registry.make_evaluator(name) as ev:
        ev.setup(scene.body, scene.cameras, scene.foreground)
        model, overlap = ev.counts(X if name != "naive" else X[:2])
    counts = {"model_pixels": np.asarray(model).tolist(), "overlap_pixels": np.asarray(overlap).tolist()}
    stored = DATA / "pixel_counts.json"
    expected = golden("pixel_counts", counts) if name == "numpy" else json.loads(stored.read_text())
    n = len(counts["model_pixels"])
    assert counts == {k: v[:n] for k, v in expected.items()}


@pytest.mark.parametrize("name", OPTIMIZERS)
def test_first_proposals_at_a_fixed_seed(name):
    optimizer = registry.make_optimizer(name)
    optimizer.setup(space(), np.random.default_rng(7))
    proposals = optimizer.ask()
    expected = np.array(golden(f"first_proposals_{name}", proposals.tolist()))
    np.testing.assert_allclose(proposals, expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("name", OPTIMIZERS)
def test_best_after_a_few_generations_at_a_fixed_seed(name):
    optimizer = registry.make_optimizer(name)
    optimizer.setup(space(), np.random.default_rng(7))
    for _ in range(GENERATIONS):
        X = optimizer.ask()
        optimizer.tell(X, objective(X))
    result = optimizer.result
    found = {
        "generations": GENERATIONS,
        "evaluations": result.evaluations,
        "fbest": result.fbest,
        "xbest": result.xbest.tolist(),
    }
    expected = golden(f"trajectory_{name}", found)
    assert (found["generations"], found["evaluations"]) == (expected["generations"], expected["evaluations"])
    np.testing.assert_allclose(found["fbest"], expected["fbest"], rtol=1e-9, atol=0)
    np.testing.assert_allclose(found["xbest"], expected["xbest"], rtol=1e-9, atol=1e-12)


def test_cmaes_candidates_of_twelve_searches_are_bit_for_bit_the_same():
    """SHA-256 over the bytes (float64, C order) of every candidate batch that CMA-ES's
    ``ask`` returns in 12 searches to the end of their budget: bounds transform and clip x
    the tracking-like sphere, ellipsoid and Rosenbrock at 39 DOF x seeds 1 and 2."""
    digest, candidates = hashlib.sha256(), 0
    for bounds in ("transform", "clip"):
        for f in TRACKING_LIKE.values():
            for seed in (1, 2):
                optimizer = registry.make_optimizer("cmaes", bounds=bounds)
                optimizer.setup(box(budget=1500), np.random.default_rng(seed))
                while not optimizer.stop():
                    X = optimizer.ask()
                    digest.update(np.ascontiguousarray(X, dtype=np.float64).tobytes())
                    candidates += X.shape[0]
                    optimizer.tell(X, f(X))
    found = {"searches": 12, "candidates": candidates, "sha256": digest.hexdigest()}
    assert found == golden("cmaes_candidates_sha256", found)
