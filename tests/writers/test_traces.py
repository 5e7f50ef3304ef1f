"""A run's convergence traces, ``traces.csv``: read back as written, and cut short or damaged
(Hypothesis: tests/helpers.py damages)."""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mmocap.writers.traces import read_traces, write_traces
from tests.helpers import damages, read_damaged

#: two frames' traces: (evaluations, best fitness so far), the fitness never rising
TRACES = {
    0: np.array([[1.0, 0.5], [4.0, 0.31], [9.0, 0.2], [12.0, 0.2]]),
    1: np.array([[1.0, 0.25], [3.0, 0.125], [12.0, 0.125]]),
}


@pytest.fixture(scope="module")
def traces_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("traces") / "traces.csv"
    write_traces(path, [SimpleNamespace(frame=frame, trace=trace) for frame, trace in TRACES.items()])
    return path, path.read_bytes()


def test_traces_read_back_as_written(traces_file):
    read = read_traces(traces_file[0])
    assert list(read) == list(TRACES)
    for frame, trace in TRACES.items():
        np.testing.assert_array_equal(read[frame], trace)


@settings(max_examples=100)
@given(data=st.data())
def test_a_cut_traces_file_is_refused_or_read_as_its_whole_rows(traces_file, data):
    """A cut inside a row is refused; a cut at a row's end gives exactly the rows kept."""
    path, whole = traces_file
    damage = data.draw(damages(whole))
    outcome = read_damaged(read_traces, path, damage, whole)
    if damage.kind == "byte" or outcome is None:
        return
    assert whole[: damage.offset].endswith(b"\n"), f"{damage}: a row cut inside was read"
    rows = np.concatenate([np.c_[np.full(len(t), f), t] for f, t in TRACES.items()])[: damage.whole_lines(whole) - 1]
    assert list(outcome[0]) == sorted(set(rows[:, 0].astype(int)))
    for frame, trace in outcome[0].items():
        np.testing.assert_array_equal(trace, rows[rows[:, 0] == frame, 1:])
