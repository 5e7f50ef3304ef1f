"""Stage "accuracy": the marker error, and the per-frame table written as a run goes."""

import numpy as np
import pandas as pd
import pytest

from mmocap.body.skeleton import parameter_names
from mmocap.io import WriteError
from mmocap.stages.accuracy import FrameLog, marker_error


def test_marker_error_is_the_mean_distance_over_the_markers_present():
    truth = np.zeros((2, 3, 3))
    estimated = truth.copy()
    estimated[0, :, 0] = [3.0, 4.0, 5.0]  # mm
    truth[1] = np.nan  # a frame without ground truth
    np.testing.assert_allclose(marker_error(estimated, truth), [4.0, np.nan])
    truth[0, 2] = np.nan  # a missing marker is skipped
    assert marker_error(estimated, truth)[0] == pytest.approx(3.5)


def log_two_frames(path):
    log = FrameLog(path)
    for frame in range(2):
        log.write(frame, 10.0 + frame, 0.5, 100, 0.25, np.full(51, 0.1 * frame))
    return log


def test_rows_go_to_a_partial_file_renamed_when_complete(tmp_path):
    path = tmp_path / "frames.csv"
    log = log_two_frames(path)
    assert log.partial.name == "frames.csv.partial"
    assert not path.exists()
    assert len(log.partial.read_text().splitlines()) == 3  # flushed row by row: a crash keeps them
    log.close()
    log.close()  # closing again does nothing
    table = pd.read_csv(path)
    assert not log.partial.exists()
    assert list(table.columns[:5]) == ["frame", "marker_error_mm", "fitness", "evaluations", "seconds"]
    assert list(table.columns[5:]) == parameter_names()
    assert table["marker_error_mm"].tolist() == [10.0, 11.0]
    assert table.iloc[1, 5] == pytest.approx(0.1)


def test_a_stopped_run_leaves_only_the_partial_file(tmp_path):
    path = tmp_path / "frames.csv"
    log = log_two_frames(path)
    log.close(complete=False)
    assert not path.exists()
    assert len(pd.read_csv(log.partial)) == 2


def test_a_log_that_cannot_be_written_names_its_file(tmp_path):
    blocker = tmp_path / "run"
    blocker.write_text("a file where the run folder should be")
    with pytest.raises(WriteError, match=f"cannot write {blocker / 'frames.csv.partial'}: {blocker} is a file"):
        FrameLog(blocker / "frames.csv")
