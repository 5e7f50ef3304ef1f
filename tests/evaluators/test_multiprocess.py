"""Multiprocessing evaluator: configuration errors and the lifecycle of workers and shared data."""

import os

import numpy as np
import pytest

from mmocap.errors import ConfigError
from mmocap.evaluators.multiprocess import MultiprocessingEvaluator
from mmocap.testing.evaluators import (
    RIGS,
    TRUE_POSE,
    BlobBody,
    masks,
    naive_counts,
    test_poses,
)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"workers": 0}, r"workers must be an integer >= 1, got 0"),
        ({"workers": 1.5}, r"workers must be an integer >= 1, got 1.5"),
        ({"inner": "multiprocessing"}, r"inner must be a single-process evaluator.*'multiprocessing'"),
        ({"inner": "nope"}, r"inner must be .*numpy.*got 'nope'"),
    ],
)
def test_bad_configuration_is_a_config_error(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        MultiprocessingEvaluator(**kwargs)


def test_workers_share_the_frame_and_stop_on_close():
    rig = "front-side-near"
    ev = MultiprocessingEvaluator(patch_scale=1.0, workers=3)
    ev.setup(BlobBody(), RIGS[rig], masks(rig, "true"))
    shared = ev._shared
    assert os.path.exists(shared)
    assert len(ev._pool) == 3
    X = test_poses()
    for n in (1, 2, len(X)):  # fewer candidates than workers, then more
        for got, expected in zip(ev.counts(X[:n]), naive_counts(rig, 1.0, "true")):
            np.testing.assert_array_equal(got, expected[:n])
    # a second frame replaces the shared file; the body is not sent again
    ev.setup(ev.body, RIGS[rig][:1], masks(rig, "empty")[:1])
    assert not os.path.exists(shared)
    assert os.path.exists(ev._shared)
    assert ev(TRUE_POSE[None]).tolist() == [1.0]
    procs, shared = [p for p, _ in ev._pool], ev._shared
    ev.close()
    assert not any(p.is_alive() for p in procs)
    assert not os.path.exists(shared)
    with pytest.raises(RuntimeError, match="setup"):
        ev(TRUE_POSE[None])
