"""The plots of a run (mmocap.writers.plots) fit their saved image, with whole-frame ticks."""

import numpy as np

from mmocap.writers import plots
from tests.helpers import assert_fits, assert_whole_frame_ticks


def test_error_per_frame_fits_with_whole_frame_ticks(tmp_path):
    errors = np.array([40.0, 55.0, 48.0])  # three frames: matplotlib would tick every quarter
    fig = plots.plot_error_per_frame(errors, tmp_path / "e.png", "a run")
    assert_fits(fig, tmp_path / "e.png")
    assert_whole_frame_ticks(fig.axes[0])
