"""Where the silhouette kernel's time goes (mmocap.bench.parts): the builds that stop after each
part, and the whole kernel among them counting as the rule does."""

import numpy as np
import pytest

from mmocap import registry
from mmocap.bench.parts import PARTS, part_options
from mmocap.testing.scene import Scene


def test_only_the_builds_that_stop_early_define_parts():
    assert not any(option.startswith("-DPARTS=") for option in part_options(len(PARTS)))
    for kept in range(1, len(PARTS)):
        assert f"-DPARTS={kept}" in part_options(kept)
        assert f"-DPART_{list(PARTS)[kept - 1]}={kept}" in part_options(kept)


def test_every_build_runs_and_the_one_that_keeps_every_part_counts_as_numpy():
    pytest.importorskip("pyopencl")
    scene = Scene(1000, 2)
    X = scene.candidates(3)
    with registry.make_evaluator("numpy") as reference:
        reference.setup(scene.body, scene.cameras, scene.foreground)
        expected = np.stack(reference.counts(X))
    counts = {}
    for kept in range(1, len(PARTS) + 1):
        with registry.make_evaluator("opencl") as ev:
            ev.build_with(part_options(kept))
            ev.setup(scene.body, scene.cameras, scene.foreground)
            counts[kept] = np.stack(ev.counts(X))
    np.testing.assert_array_equal(counts[len(PARTS)], expected)
    assert expected[0].min() > 0
    assert not np.array_equal(counts[len(PARTS) - 1], expected)  # stopped before the count
