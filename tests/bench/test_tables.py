"""Cano Tables 1 and 2 (mmocap.bench.tables): how many frames a backend's frame time is the mean of."""

import time

import numpy as np
import pytest

from mmocap.bench.tables import frame_ms
from mmocap.testing.scene import Scene


class CountingEvaluator:
    """A stand-in evaluator that counts its calls; each call takes ``delay`` seconds."""

    def __init__(self, delay: float):
        self.delay, self.calls = delay, 0

    def setup(self, body, cameras, foreground):
        pass

    def __call__(self, X):
        self.calls += 1
        time.sleep(self.delay)
        return np.random.default_rng(self.calls).random(len(X))


@pytest.fixture(scope="module")
def small_scene():
    return Scene(2000, cameras=1)


@pytest.mark.parametrize(
    ("delay", "frames", "seconds", "expected"),
    [
        (0.0, 1, 0.0, 1),  # no time budget: the frames asked for
        (0.0, 2, 10.0, 5),  # fast frames: more, up to MAX_FRAMES
        (0.02, 1, 0.1, 1),  # a frame of 10 calls takes 0.2 s: no second one within 0.1 s
        (0.02, 3, 0.1, 3),  # but never fewer than asked for
    ],
)
def test_frame_ms_adds_frames_that_fit_in_the_time_given(small_scene, delay, frames, seconds, expected):
    ev = CountingEvaluator(delay)
    frame_ms(ev, small_scene, 140, frames, seconds)
    # the warm-up call, then per frame the start pose and CMA-ES's 10 calls (139 evaluations)
    assert ev.calls == 1 + expected * (1 + 10)
