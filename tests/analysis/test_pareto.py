"""Non-dominated configurations on (time, error), both minimised, and their summary table."""

import itertools

import numpy as np
import pandas as pd
import pytest

from mmocap.analysis.pareto import non_dominated, summarise
from mmocap.errors import DataError


def brute_force_front(points):
    """Reference: a point is on the front when no other is <= everywhere and < somewhere."""
    return np.array([not any(np.all(q <= p) and np.any(q < p) for q in points) for p in points])


def test_hand_made_front():
    #            fast+bad  slow+good  dominated  middle   equal to middle
    points = [[1.0, 9.0], [9.0, 1.0], [5.0, 6.0], [4.0, 4.0], [4.0, 4.0]]
    assert non_dominated(np.array(points)).tolist() == [True, True, False, True, True]


def test_ties_on_one_objective():
    # same time, different error: only the lower error survives; same error, faster survives
    points = np.array([[2.0, 5.0], [2.0, 3.0], [1.0, 3.0]])
    assert non_dominated(points).tolist() == [False, False, True]


def test_random_points_match_the_definition():
    rng = np.random.default_rng(0)
    for n, m in itertools.product((1, 2, 7, 40), (2, 3)):
        points = rng.integers(0, 6, size=(n, m)).astype(float)  # many ties
        front = non_dominated(points)
        assert front.tolist() == brute_force_front(points).tolist()
        assert front.any()


def runs_table():
    rows = []
    for vertices, evaluations, backend, seconds, error in [
        (3000, 150, "numpy", 1.0, 40.0),
        (3000, 450, "numpy", 3.0, 30.0),
        (5000, 150, "numpy", 2.0, 42.0),
        (5000, 450, "numpy", 6.0, 25.0),
        (3000, 150, "opencl", 0.2, 40.0),
        (3000, 450, "opencl", 0.6, 30.0),
        (5000, 150, "opencl", 0.4, 42.0),
        (5000, 450, "opencl", 1.2, 25.0),
    ]:
        for seed, jitter in ((0, -0.1), (1, 0.1)):  # two runs per configuration, mean = value
            rows.append(
                dict(
                    vertices=vertices,
                    evaluations=evaluations,
                    backend=backend,
                    seed=seed,
                    seconds_per_frame=seconds + jitter,
                    mean_marker_error_mm=error + jitter,
                )
            )
    return pd.DataFrame(rows)


def test_summarise_averages_runs_and_marks_the_front():
    table = summarise(runs_table())
    assert len(table) == 8
    assert (table["runs"] == 2).all()
    assert table["seconds_per_frame"].is_monotonic_increasing
    front = table[table.pareto]
    # every numpy configuration is dominated by its faster opencl twin, and opencl 5000x150
    # (0.4 s, 42 mm) by opencl 3000x150 (0.2 s, 40 mm)
    assert list(zip(front.backend, front.vertices, front.evaluations)) == [
        ("opencl", 3000, 150),
        ("opencl", 3000, 450),
        ("opencl", 5000, 450),
    ]
    assert front["mean_marker_error_mm"].tolist() == pytest.approx([40.0, 30.0, 25.0])


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda t: t.drop(columns="backend"), "missing column(s) 'backend'"),
        (lambda t: t.iloc[0:0], "no runs to compare"),
        (
            lambda t: t.assign(seconds_per_frame=t.seconds_per_frame.where(t.index != 3, np.nan)),
            "'seconds_per_frame' holds 1 NaN or infinite value(s) (an empty cell is NaN), the first in data row 4",
        ),
        (
            lambda t: t.assign(mean_marker_error_mm=t.mean_marker_error_mm.astype(object).where(t.index != 0, "x")),
            "the first 'x' in data row 1",
        ),
    ],
)
def test_bad_runs_are_clear_errors(damage, message):
    with pytest.raises(DataError) as err:
        summarise(damage(runs_table()), source="sweep/runs.csv")
    assert str(err.value).startswith("sweep/runs.csv: ")
    assert message in str(err.value)


def test_a_run_without_its_configuration_is_refused_not_dropped():
    runs = pd.DataFrame(
        {
            "algorithm": ["cmaes", None, "pso"],
            "dof": [39, 39, 39],
            "vertices": [1000] * 3,
            "evaluations": [500] * 3,
            "mean_marker_error_mm": [10.0, 5.0, 12.0],
            "seconds_per_frame": [1.0, 0.5, 0.8],
        }
    )
    with pytest.raises(DataError, match="column 'algorithm' has 1 empty cell"):
        summarise(
            runs,
            by=["algorithm", "dof", "vertices", "evaluations"],
            objectives=["mean_marker_error_mm", "seconds_per_frame"],
        )


def test_means_near_the_float_limit_do_not_overflow():
    moderate = runs_table()
    huge = moderate.assign(
        seconds_per_frame=moderate.seconds_per_frame * 1e307, mean_marker_error_mm=moderate.mean_marker_error_mm * 4e306
    )
    a, b = summarise(moderate), summarise(huge)
    assert np.isfinite(b[["seconds_per_frame", "mean_marker_error_mm"]].to_numpy()).all()
    assert b["pareto"].tolist() == a["pareto"].tolist()
    np.testing.assert_allclose(b["mean_marker_error_mm"] / 4e306, a["mean_marker_error_mm"], rtol=1e-12)


def test_equal_mean_objectives_are_equal():
    """Errors [6, 6, 4] and [6, 5, 5] both average 16/3; as sums of v / 3 they differed in the
    last bit, and the first configuration dominated the second."""
    runs = pd.DataFrame(
        {"setting": ["a"] * 3 + ["b"] * 3 + ["c"], "seconds": [2.0] * 7, "error": [6.0, 6.0, 4.0, 6.0, 5.0, 5.0, 9.0]}
    )
    table = summarise(runs, by=["setting"], objectives=["seconds", "error"]).set_index("setting")
    assert table.loc["a", "error"] == table.loc["b", "error"] == 16 / 3
    assert table["pareto"].to_dict() == {"a": True, "b": True, "c": False}
