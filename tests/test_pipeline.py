"""Tracking through the Python API on the tiny sequence: accuracy, crash-safe output, and the
plausibility warnings of a run whose foreground the model cannot explain."""

import functools
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mmocap.body.model import BodyModel
from mmocap.data.sequence import Sequence
from mmocap.errors import MmocapWarning
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.optimizers.cmaes import CMAES
from mmocap.stages.accuracy import FrameLog, marker_error
from mmocap.stages.background import GaussianBackground
from mmocap.stages.foreground import Foreground
from mmocap.stages.tracking import Holistic, track
from tests.helpers import box_in_the_scene, compose_config


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


#: a short automatic start (about 900 evaluations)
QUICK_START = [
    "start.mode=search",
    "start.headings=4",
    "start.candidates=1",
    "start.refined=1",
    "start.evaluations=80",
    "start.limb_evaluations=40",
    "start.limb_samples=20",
    "start.limb_restarts=1",
    "start.rounds=1",
    "start.height_steps_mm=[]",
    "start.shape_evaluations=40",
    "start.shape_passes=1",
    "start.hull_height_offsets_mm=[0]",
]


def with_a_box(sequence, tmp_path) -> Path:
    """A copy of ``sequence`` with a box in the scene (:func:`tests.helpers.box_in_the_scene`)."""
    copy = Path(shutil.copytree(sequence, tmp_path / "data" / sequence.name))
    box_in_the_scene(copy)
    return copy


def run_tiny(sequence, out, *extra) -> dict:
    """The tiny sequence folder tracked for 3 frames at 150 evaluations; its summary."""
    from mmocap.pipeline import run

    cfg = compose_config(
        "dataset=folder",
        f"dataset.root={sequence}",
        "evaluator=numpy",
        "body.vertices=1000",
        "tracking.evaluations=150",
        "tracking.frames=3",
        "overlays=0",
        "progress=false",
        "foreground_cache=null",
        *extra,
    )
    return run(cfg, out)


def test_a_correct_run_records_its_fitness_and_no_plausibility_warning(tiny_sequence, tmp_path, recwarn):
    summary = run_tiny(tiny_sequence, tmp_path / "run")
    assert summary["mean_best_fitness"] == pytest.approx(
        np.mean(pd.read_csv(tmp_path / "run" / "frames.csv")["fitness"]),
        abs=1e-6,  # the file's 6 decimals
    )
    assert summary["mean_best_fitness"] < 0.1  # measured: 0.073
    assert summary["plausibility"] == []
    assert summary["warnings"] == []
    assert not [w for w in recwarn if issubclass(w.category, MmocapWarning)]


def test_a_foreground_the_model_cannot_explain_is_warned_and_recorded(tiny_sequence, tmp_path):
    boxed = with_a_box(tiny_sequence, tmp_path)
    with pytest.warns(MmocapWarning, match="the run's mean fitness is") as shown:
        summary = run_tiny(boxed, tmp_path / "run")
    assert summary["mean_best_fitness"] > 0.3  # measured: 0.40
    (finding,) = summary["plausibility"]
    assert finding["check"] == "mean_fitness"
    assert finding["value"] == pytest.approx(summary["mean_best_fitness"], abs=1e-4)
    assert finding["message"] in summary["warnings"]
    messages = [str(w.message) for w in shown if issubclass(w.category, MmocapWarning)]
    # the box is a second region beside the person in some cameras, warned of once each
    assert [m for m in messages if "person-sized regions" not in m] == [finding["message"]]


def test_an_automatic_start_on_that_foreground_is_warned_with_its_body_recorded(tiny_sequence, tmp_path):
    boxed = with_a_box(tiny_sequence, tmp_path)
    with pytest.warns(MmocapWarning) as shown:
        summary = run_tiny(boxed, tmp_path / "run", *QUICK_START, "tracking.frames=1")
    checks = [finding["check"] for finding in summary["plausibility"]]
    assert checks[0] == "start_fitness"  # measured: 0.62
    assert "mean_fitness" in checks  # measured: 0.61
    fitness_warnings = [str(w.message) for w in shown if "fitness is" in str(w.message)]
    assert fitness_warnings[0].startswith("the automatic start's fitness is")
    assert summary["start"]["fitness"] > 0.3
    assert {"hull_height_mm", "body_height_mm", "body_girth"} <= set(summary["start"])
    assert summary["body"]["height_mm"] == summary["start"]["body_height_mm"]
    assert all(finding["message"] in summary["warnings"] for finding in summary["plausibility"])
