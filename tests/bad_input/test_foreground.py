"""Cameras whose foreground is empty or nearly the whole image: the run stops naming the
camera (``coverage.action=stop``, the default) or tracks without it, warned and recorded
(``coverage.action=drop``). Before this check, black images gave 451 mm with exit 0.

A foreground that the body model cannot explain (mmocap.stages.plausibility): the run ends,
warned and recorded. Before this check, a lossy recording ended at 249.5 mm with exit 0."""

import json

import cv2
import numpy as np
import pytest

from tests.helpers import assert_clean_error, assert_warned, box_in_the_scene, track_args
from tests.helpers import mmocap_in_process as mmocap


def paint(sequence, camera: str, value: int) -> None:
    """Every image of ``camera`` in the sequence replaced by one flat grey ``value``."""
    for path in sorted((sequence / "images" / camera).glob("*.png")):
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        assert cv2.imwrite(str(path), np.full_like(image, value))


@pytest.mark.parametrize(
    ("camera", "value"),
    [("BW1", 0), ("C1", 0), ("C1", 255)],
    ids=["black-greyscale-camera", "black-colour-camera", "white-colour-camera"],
)
def test_a_blind_camera_stops_the_run_naming_it(sequence_copy, tmp_path, camera, value):
    paint(sequence_copy, camera, value)
    out = tmp_path / "run"
    line = assert_clean_error(mmocap(*track_args(sequence_copy, out)), f"camera {camera}", "coverage.action=drop")
    assert "foreground covers" in line
    assert not (out / "summary.json").exists()


def test_drop_tracks_without_the_blind_camera_and_records_why(sequence_copy, tmp_path):
    paint(sequence_copy, "BW1", 0)
    out = tmp_path / "run"
    outcome = mmocap(*track_args(sequence_copy, out), "coverage.action=drop")
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
    assert_warned(outcome, summary, "camera BW1", "dropped")
    assert summary["frames"] == 2


def test_a_bad_action_is_a_config_error(sequence_copy, tmp_path):
    assert_clean_error(
        mmocap(*track_args(sequence_copy, tmp_path / "run"), "coverage.action=ignore"), "coverage.action"
    )


def test_a_foreground_the_model_explains_poorly_is_warned_and_recorded(sequence_copy, tmp_path):
    box_in_the_scene(sequence_copy)
    out = tmp_path / "run"
    outcome = mmocap(*track_args(sequence_copy, out))
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
    line = assert_warned(outcome, summary, "mean fitness", "plausibility.max_fitness=0.2", "foreground")
    warned = [w for w in outcome.stderr.splitlines() if w.startswith("mmocap: warning:")]
    # besides the fit, the box is a second person-sized region in a camera or two
    assert [w for w in warned if "person-sized regions" not in w] == [line]
    assert [finding["check"] for finding in summary["plausibility"]] == ["mean_fitness"]
    assert summary["mean_best_fitness"] > 0.3  # measured: 0.39; 0.09 without the box
