"""Loss of track: a frame whose fitness jumps is searched again, and the recovery is logged."""

from types import SimpleNamespace

import numpy as np
import pytest

from mmocap.body.model import BodyModel
from mmocap.body.skeleton import parameter_index
from mmocap.errors import ConfigError
from mmocap.optimizers.cmaes import CMAES
from mmocap.stages.recovery import Recovery
from mmocap.stages.tracking import Holistic, track

KNEE = parameter_index("LKnee.rx")
JUMP_FRAME = 3
BUDGET = 300


@pytest.fixture(scope="module")
def body():
    return BodyModel("S1", vertices=1000)


class JumpingTarget:
    """A fitness around a target pose per frame (0.02 at the target, rising to 1): the left
    knee bends by 1.5 rad at ``jump`` (out of a tracking step's box) and stays bent. Its
    ``setup`` takes the frame number as the 'masks'."""

    def __init__(self, x0: np.ndarray, jump: int | None):
        self.x0, self.jump, self.frame = x0, jump, 0

    def target(self) -> np.ndarray:
        x = self.x0.copy()
        if self.jump is not None and self.frame >= self.jump:
            x[KNEE] += 1.5
        return x

    def setup(self, body, cameras, masks):
        self.frame = masks

    def __call__(self, X):
        d = (X - self.target()) / np.where(np.arange(X.shape[1]) < 3, 100.0, 1.0)
        return 0.02 + np.minimum(0.98, 0.2 * np.sum(d**2, axis=1))


def run(body, jump, recovery):
    x0 = body.rest_pose()
    sequence = SimpleNamespace(n_frames=6, x0=x0, root="fake")
    foreground = SimpleNamespace(cameras=[], masks=lambda frame: frame)
    return track(
        sequence,
        body,
        foreground,
        JumpingTarget(x0, jump),
        CMAES(sigma0=0.1),
        Holistic(),
        evaluations=BUDGET,
        seed=0,
        recovery=recovery,
    )


def test_a_jump_is_recovered_once_at_its_frame_and_logged(body):
    recovery = Recovery(limb_evaluations=300, evaluations=300)
    results = run(body, JUMP_FRAME, recovery)
    assert [event.frame for event in recovery.events] == [JUMP_FRAME]
    event = recovery.events[0]
    assert event.fitness_before > 0.1
    assert event.fitness_after < 0.05
    assert results[JUMP_FRAME].evaluations == BUDGET + event.evaluations
    assert all(r.fitness < 0.05 for r in results[JUMP_FRAME:])  # the knee followed from then on
    assert set(event.summary()) == {"frame", "fitness_before", "fitness_after", "evaluations"}


def test_without_recovery_the_track_lags_behind_for_frames(body):
    lagging = run(body, JUMP_FRAME, Recovery(enabled=False))
    recovered = run(body, JUMP_FRAME, Recovery(limb_evaluations=300, evaluations=300))
    assert lagging[JUMP_FRAME].fitness > 0.1  # the knee lies outside the frame's box
    assert sum(r.fitness for r in lagging) > sum(r.fitness for r in recovered) + 0.1


def test_a_smooth_run_is_never_searched_again(body):
    recovery = Recovery()
    results = run(body, None, recovery)
    assert recovery.events == []
    assert all(r.evaluations == BUDGET for r in results)


@pytest.mark.parametrize(
    ("key", "value"),
    [("enabled", "yes"), ("window", 0), ("jump", 1.0), ("max_fitness", 0), ("limb_evaluations", 1), ("widen", 0.5)],
)
def test_a_bad_setting_names_its_key(key, value):
    with pytest.raises(ConfigError, match=f"recovery.{key}"):
        Recovery(**{key: value})
