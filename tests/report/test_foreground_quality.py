"""`mmocap foreground-quality`: its options are checked before any work, and a true
silhouette must match its image (the scores are checked in tests/stages/test_foreground.py)."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from mmocap.errors import DataError
from mmocap.report.foreground_quality import evaluate
from mmocap.stages import segmentation
from tests.helpers import TINY, run_cli


class AllForeground:
    """A background model that calls every pixel foreground."""

    needs_plate = True

    def fit(self, frames, name):
        return self

    def find_person(self, image, name):
        return np.ones(image.shape[:2], bool), None


def fake_sequence(truth_shape):
    """One camera C1, one 4x6 frame, a true silhouette of ``truth_shape``."""
    return SimpleNamespace(
        n_frames=1,
        root=Path("seq"),
        cameras=[SimpleNamespace(name="C1")],
        background=lambda cam: [],
        images=lambda frame: [np.zeros((4, 6), np.uint8)],
        silhouette=lambda frame, cam: np.ones(truth_shape, bool),
    )


def test_counts_pool_over_frames():
    assert evaluate(fake_sequence((4, 6)), AllForeground).tolist() == [[24, 0, 0]]


def test_a_silhouette_of_another_size_names_the_camera_and_frame():
    with pytest.raises(DataError, match=r"camera C1, frame 0: the true silhouette is 3x2 px but the image 6x4 px"):
        evaluate(fake_sequence((2, 3)), AllForeground)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--methods", ""], "--methods '' has an empty name"),
        (["--methods", "horprasert,,knn"], "--methods 'horprasert,,knn' has an empty name"),
        (["--crf", "0,x"], "--crf '0,x': give H.264 qualities from 0 (lossless) to 51"),
        (["--crf", "60"], "--crf '60': give H.264 qualities"),
        (["--csv", "{tmp}"], "--csv {tmp} is a folder"),
        (["--md", "{tmp}"], "--md {tmp} is a folder"),
        (["--csv", "{tmp}/notes/q.csv"], "cannot write {tmp}/notes: {tmp}/notes is a file"),
    ],
)
def test_bad_options_fail_before_any_work(tmp_path, capsys, options, message):
    (tmp_path / "notes").write_text("")
    options = [o.format(tmp=tmp_path) for o in options]
    defaults = ["--csv", tmp_path / "q.csv", "--md", tmp_path / "q.md"]
    assert run_cli("foreground-quality", *defaults, *options) == 2
    assert capsys.readouterr().err.startswith(f"mmocap: error: {message.format(tmp=tmp_path)}")


@pytest.mark.skipif(not segmentation.available(), reason="the segment extra is not installed")
def test_person_segmentation_is_measured_beside_the_background_models(tmp_path):
    csv, md = tmp_path / "fg.csv", tmp_path / "fg.md"
    settings = {"frames": 2, "width": 640, "height": 480, "background_frames": 3, "seed": TINY["seed"]}
    overrides = [f"dataset.root={tmp_path / 'data'}", "progress=false", "dataset.cameras=[C1,C2,BW1]"]
    overrides += [f"dataset.{key}={value}" for key, value in settings.items()]
    methods = ["--methods", "horprasert,segmentation"]
    assert run_cli("foreground-quality", *methods, "--csv", csv, "--md", md, *overrides) == 0
    table = pd.read_csv(csv).set_index(["method", "camera"])
    # measured 0.77: it finds nobody in one of C1's two frames (recall 0.49), 0.96-0.97 elsewhere
    assert table.loc[("segmentation", "all"), "iou"] > 0.7
    assert table.loc[("horprasert", "all"), "iou"] > 0.85
    assert "segmentation P / R / IoU" in md.read_text()
