"""Golden results: what must not change, and does not depend on the CPU's float path.

- the exact pixel counts |M| and |M & F| (integers, by the fitness rule) of six fixed poses
  of the 2000-vertex body in three 640x480 views, for every evaluator that runs here;
- each built-in optimiser's first proposals at a fixed seed (they come from the generator
  alone).

A change that moves them on purpose regenerates the files with ``make golden``
(``MMOCAP_REGEN_GOLDEN=1 pytest tests/golden``); the diff of ``tests/golden/data/`` then
shows what moved. Tracked poses are not golden: CMA-ES's eigendecompositions make them
differ from one BLAS kernel to another after the first frames (see
``tests/test_pipeline.py``, which checks them statistically).
"""
import json
import os
from pathlib import Path

import numpy as np
import pytest

from mmocap import registry
from mmocap.api import SearchSpace
from mmocap.testing.scene import Scene

DATA = Path(__file__).with_name("data")
REGENERATE = os.environ.get("MMOCAP_REGEN_GOLDEN") == "1"
EVALUATORS = ["numpy", "naive", "opencl"]  # numpy first: it writes the file when regenerating
OPTIMIZERS = ["cmaes", "de", "pso", "apf", "psapf"]


def golden(name: str, value):
    """The stored value of ``name`` (``value`` written instead when regenerating)."""
    path = DATA / f"{name}.json"
    if REGENERATE:
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps(value, indent=1) + "\n")
    return json.loads(path.read_text())


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
    dim = 12
    space = SearchSpace(x0=np.linspace(-0.2, 0.3, dim), lower=np.full(dim, -1.0), upper=np.full(dim, 1.0),
                        radius=np.full(dim, 0.5), budget=600,
                        partitions=(np.arange(0, 3), np.arange(3, 7), np.arange(7, 12)))
    optimizer = registry.make_optimizer(name)
    optimizer.setup(space, np.random.default_rng(7))
    proposals = optimizer.ask()
    expected = np.array(golden(f"first_proposals_{name}", proposals.tolist()))
    np.testing.assert_allclose(proposals, expected, rtol=1e-12, atol=1e-15)
