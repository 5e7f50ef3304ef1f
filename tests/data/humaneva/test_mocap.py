"""The ``.mat`` marker files as HumanEva-I's, markers between mocap frames, and the marker map."""

import numpy as np
import pytest
import scipy.io
from hypothesis import given, settings
from hypothesis import strategies as st

from mmocap.body.model import MARKER_NAMES
from mmocap.data.humaneva.mocap import read_mocap, sample_mocap, write_mocap
from mmocap.data.sequence import Sequence
from mmocap.errors import DataError
from tests.helpers import HE_FIRST, HE_FRAMES, HE_LEAD, HE_LEAD_IN, Damage, damages, open_he, read_damaged


def test_markers_at_fractional_mocap_indices_are_interpolated():
    """Between neighbours; NaN where one is missing or outside the recording."""
    mocap = np.arange(5, dtype=float)[:, None, None] * np.ones((1, 2, 3))
    mocap[3, 1] = np.nan
    out = sample_mocap(mocap, [1.0, 2.5, 4.0, 5.0, 5.5, 0.5])
    np.testing.assert_allclose(out[:4, 0, 0], [0.0, 1.5, 3.0, 4.0])
    assert np.isnan(out[2, 1]).all()
    assert not np.isnan(out[1, 1]).any()
    assert np.isnan(out[4:]).all()  # outside the recording


def test_mocap_file_has_the_real_structure(synthetic, exported):
    mat = scipy.io.loadmat(str(exported / "S1/Mocap_Data/Walking_1.mat"))
    groups = mat["ParameterGroup"]
    point = groups[0, [str(g[0, 0][0]) for g in groups[0]["name"]].index("POINT")]
    params = point["Parameter"]
    names = [str(p[0, 0][0]) for p in params[0]["name"]]
    labels = [str(x[0]) for x in params[0, names.index("LABELS")]["data"][0]]
    rate = float(np.squeeze(params[0, names.index("RATE")]["data"]))
    assert {"LFHD", "C7", "LSHO", "RANK"} <= set(labels)
    assert rate == 120.0
    # 120 Hz: the lead, stored as zeros (missing), the first frame held over the lead-in
    # images, then (frames - 1) * 2 + 1 samples
    assert mat["Markers"].shape == (HE_FIRST + 2 * (HE_FRAMES - 1) + 1, len(labels), 3)
    assert np.all(mat["Markers"][:HE_LEAD] == 0)
    held = mat["Markers"][HE_LEAD : HE_FIRST + 1]
    np.testing.assert_array_equal(held, np.repeat(mat["Markers"][HE_FIRST : HE_FIRST + 1], 2 * HE_LEAD_IN + 1, axis=0))
    truth = Sequence.open(synthetic).markers()
    ankle = labels.index("RANK")
    np.testing.assert_allclose(mat["Markers"][HE_FIRST + 1, ankle], truth[:2, MARKER_NAMES.index("r_ankle")].mean(0))


def test_mocap_without_a_mapped_label(damaged):
    path = damaged / "S1/Mocap_Data/Walking_1.mat"
    labels, markers = read_mocap(path)
    labels[labels.index("LELB")] = "LELX"
    write_mocap(path, labels, markers)
    with pytest.raises(DataError, match=r"Walking_1.mat has no marker labelled LELB \(mapped to 'l_elbow'"):
        open_he(damaged)


# --- files cut short or damaged (Hypothesis: tests/helpers.py damages) -----------------------

#: labels and (mocap frames, L, 3) mm markers of the small .mat file the property tests damage
SMALL_LABELS = ["LKNE", "RKNE", "C7"]
SMALL_MOCAP = np.round(np.random.default_rng(5).uniform(-900, 1800, (3, len(SMALL_LABELS), 3)), 3)


@pytest.fixture(scope="module")
def mocap_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("mocap") / "Walking_1.mat"
    write_mocap(path, SMALL_LABELS, SMALL_MOCAP)
    return path, path.read_bytes()


@settings(max_examples=30)  # each read forks a process
@given(data=st.data())
def test_a_damaged_mocap_file_is_refused_or_read_as_it_says(mocap_file, data):
    """A cut ``.mat`` file is refused, or holds every variable still (only padding lost): read
    whole; a byte changed is refused or read (a number for a number cannot be told)."""
    path, whole = mocap_file
    damage = data.draw(damages(whole))
    outcome = read_damaged(read_mocap, path, damage, whole)
    if outcome is not None:
        labels, markers = outcome[0]
        assert markers.shape[1:] == (len(labels), 3)
        if damage.kind == "cut":
            assert labels == SMALL_LABELS
            np.testing.assert_array_equal(markers, SMALL_MOCAP)


def test_a_file_that_crashes_scipy_s_reader_is_refused(mocap_file):
    """The array flags of the first variable all set: scipy's reader dies of a segmentation
    fault in the child process, and the file is refused with one line."""
    path, whole = mocap_file
    damaged = path.with_name("crashing.mat")
    damaged.write_bytes(Damage("byte", 145, 255).apply(whole))
    with pytest.raises(DataError, match=r"crashing.mat: scipy's reader crashed on it; is it damaged"):
        read_mocap(damaged)
