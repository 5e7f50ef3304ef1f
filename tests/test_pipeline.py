"""Tracking through the Python API on the tiny sequence: accuracy and crash-safe output."""

import functools

import numpy as np
import pandas as pd

from mmocap.body.model import BodyModel
from mmocap.data.sequence import Sequence
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.optimizers.cmaes import CMAES
from mmocap.stages.accuracy import FrameLog, marker_error
from mmocap.stages.background import GaussianBackground
from mmocap.stages.foreground import Foreground
from mmocap.stages.tracking import Holistic, track


def test_tracking_recovers_the_pose_from_a_perturbed_start(tiny_sequence, tmp_path):
    """From a start 30 mm and 0.06 rad per angle off (about 69 mm of marker error), CMA-ES
    brings 3 frames well below it. One run moves a lot with the seed and the CPU's float
    path (seeds 0-7 here: means of 21.9-47.5 mm, median 27), so five seeds are run and
    their median is checked, with every run below the start."""
    seq = Sequence.open(tiny_sequence)
    seq.meta["x0"] = (seq.x0 + np.r_[30.0, -20.0, 25.0, np.full(48, 0.06)]).tolist()
    body = BodyModel("S1", vertices=13695)
    fg = Foreground(seq, functools.partial(GaussianBackground), cache_dir=tmp_path / "cache")
    truth = seq.markers()
    start_error = marker_error(body.markers(body.clip(seq.x0[None])), truth[:1])[0]
    means = []
    for seed in range(5):
        log = FrameLog(tmp_path / "frames.csv")
        results = track(
            seq,
            body,
            fg,
            NumpyEvaluator(patch_scale=1.5),
            CMAES(sigma0=0.1),
            Holistic(),
            evaluations=1500,
            seed=seed,
            frames=3,
            on_frame=lambda r, log=log: log.write(r.frame, 0.0, r.fitness, r.evaluations, r.seconds, r.pose),
        )
        log.close()
        errors = marker_error(body.markers(np.stack([r.pose for r in results])), truth[:3])
        assert all(r.evaluations == 1500 for r in results)
        means.append(errors.mean())
    assert start_error > 50
    assert max(means) < start_error, (start_error, means)
    assert np.median(means) < start_error / 2, (start_error, means)
    table = pd.read_csv(tmp_path / "frames.csv")
    assert list(table["frame"]) == [0, 1, 2]
    assert table.shape[1] == 5 + 51
