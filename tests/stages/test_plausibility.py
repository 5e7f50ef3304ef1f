"""The plausibility checks: the start's and the run's fitness, the fitted body against a
person's size and against the visual hull."""

from types import SimpleNamespace

import numpy as np
import pytest

from mmocap.body.mesh import SubjectDimensions
from mmocap.errors import ConfigError, MmocapWarning
from mmocap.stages.plausibility import Plausibility


def start(fitness=0.05, height_mm=1780.0, girth=1.0, hull_height_mm=1820.0):
    """What :meth:`AutoStart.find` returns, as far as the checks read it."""
    body = SimpleNamespace(subject=SubjectDimensions("S1", height_mm, girth))
    # the hybrid fitness is larger: the checks read the silhouettes' alone
    return SimpleNamespace(fitness=fitness + 0.5, silhouette_fitness=fitness, body=body, height_mm=hull_height_mm)


def test_a_plausible_start_and_run_give_no_warning(recwarn):
    checks = Plausibility()
    checks.check_start(start())
    checks.check_run(0.06)
    checks.check_run(float("nan"))  # a frame without a finite fitness: not known, not a warning
    assert checks.findings() == []
    assert not [w for w in recwarn if issubclass(w.category, MmocapWarning)]


@pytest.mark.parametrize(
    ("result", "check", "words"),
    [
        (start(fitness=0.37), "start_fitness", ["fitness is 0.370", "plausibility.max_fitness=0.2"]),
        (
            start(height_mm=2260.0, hull_height_mm=2290.0),
            "body_height_mm",
            ["2260 mm tall", "plausibility.min_height_mm-max_height_mm=1400-2000"],
        ),
        (start(girth=0.6), "body_girth", ["girth 0.60", "plausibility.min_girth-max_girth=0.7-1.5"]),
        (
            start(height_mm=1780.0, hull_height_mm=2100.0),
            "height_against_hull_mm",
            ["1780 mm tall", "visual hull 2100 mm", "320 mm apart", "plausibility.hull_tolerance_mm=200"],
        ),
    ],
    ids=["fitness", "height", "girth", "hull"],
)
def test_an_implausible_start_is_one_warning_naming_the_figure_and_threshold(result, check, words):
    checks = Plausibility()
    with pytest.warns(MmocapWarning) as shown:
        checks.check_start(result)
    assert len(shown) == 1
    message = str(shown[0].message)
    assert "\n" not in message
    for word in [*words, "check the foreground", "background", "calibration"]:
        assert word in message, message
    assert [(f["check"], f["message"]) for f in checks.findings()] == [(check, message)]


def test_a_run_whose_mean_fitness_is_too_high_is_warned_and_recorded():
    checks = Plausibility(max_fitness=0.15)
    with pytest.warns(MmocapWarning, match=r"the run's mean fitness is 0\.160, above plausibility\.max_fitness=0\.15"):
        checks.check_run(0.16)
    (finding,) = checks.findings()
    assert finding["check"] == "mean_fitness"
    assert finding["value"] == pytest.approx(0.16)
    assert finding["limit"] == 0.15


def test_the_findings_are_json_values():
    checks = Plausibility()
    with pytest.warns(MmocapWarning):
        checks.check_start(start(fitness=np.float64(0.5), height_mm=2290.0, girth=1.55, hull_height_mm=1700.0))
    findings = checks.findings()
    assert [f["check"] for f in findings] == ["start_fitness", "body_height_mm", "body_girth", "height_against_hull_mm"]
    for finding in findings:
        assert type(finding["value"]) is float
        assert isinstance(finding["limit"], (float, list))


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("max_fitness", 0),
        ("max_fitness", 1.5),
        ("min_height_mm", 900),
        ("max_height_mm", 1300),  # below min_height_mm
        ("min_girth", "thin"),
        ("max_girth", 0.65),  # below min_girth
        ("hull_tolerance_mm", -1),
    ],
)
def test_a_bad_setting_names_its_key(key, value):
    with pytest.raises(ConfigError, match=f"plausibility.{key}"):
        Plausibility(**{key: value})
