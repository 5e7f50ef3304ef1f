"""evaluator=auto: opencl where it works, else numpy, said in one log line; the run's
summary names the backend that ran."""

import json
import logging

import numpy as np
import pytest

from mmocap import registry
from mmocap.evaluators import auto
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.evaluators.opencl import OpenCLEvaluator, check_scene
from mmocap.testing.evaluators import RIGS, BlobBody, masks, naive_counts, test_poses
from tests.helpers import mmocap, overrides

OPENCL_HERE = OpenCLEvaluator.unavailable() is None
needs_opencl = pytest.mark.skipif(not OPENCL_HERE, reason="no usable OpenCL device here")


@pytest.fixture(autouse=True)
def fresh_choice():
    """Each test decides afresh (the choice is cached per process)."""
    auto.choose.cache_clear()
    yield
    auto.choose.cache_clear()


def auto_lines(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == auto.__name__]


@needs_opencl
def test_opencl_is_chosen_where_it_works_and_counts_as_naive(caplog):
    caplog.set_level(logging.INFO)
    ev = registry.make_evaluator("auto", patch_scale=1.7)
    assert isinstance(ev, OpenCLEvaluator)
    assert ev.name == "opencl"
    assert ev.patch_scale == 1.7
    [line] = auto_lines(caplog)
    assert line.startswith("evaluator=auto chose opencl: OpenCL device ")
    assert "counts a test scene exactly as numpy does" in line
    rig = "front-side-near"
    ev.setup(BlobBody(), RIGS[rig], masks(rig, "true"))
    for got, expected in zip(ev.counts(test_poses()), naive_counts(rig, 1.7, "true")):
        np.testing.assert_array_equal(got, expected)
    ev.close()


def test_numpy_when_opencl_is_unavailable(monkeypatch, caplog):
    caplog.set_level(logging.INFO)
    monkeypatch.setattr(OpenCLEvaluator, "unavailable", classmethod(lambda cls: "no device (test)"))
    ev = registry.make_evaluator("auto", patch_scale=1.5)
    assert isinstance(ev, NumpyEvaluator)
    assert ev.name == "numpy"
    assert ev.patch_scale == 1.5
    assert auto_lines(caplog) == ["evaluator=auto chose numpy: OpenCL is unavailable: no device (test)"]


def test_numpy_when_the_opencl_check_fails(monkeypatch, caplog):
    caplog.set_level(logging.INFO)

    def broken():
        raise RuntimeError("clBuildProgram failed: BUILD_PROGRAM_FAILURE\n(the build log)")

    monkeypatch.setattr(OpenCLEvaluator, "unavailable", classmethod(lambda cls: None))
    monkeypatch.setattr(auto, "check_opencl", broken)
    assert auto.auto_evaluator().name == "numpy"
    assert auto_lines(caplog) == [
        "evaluator=auto chose numpy: the OpenCL check failed: "
        "RuntimeError: clBuildProgram failed: BUILD_PROGRAM_FAILURE"
    ]


@needs_opencl
def test_numpy_when_opencl_counts_differently(monkeypatch):
    class OffByOne(OpenCLEvaluator):
        def _counts(self, X):
            model_px, overlap_px = super()._counts(X)
            return model_px + 1, overlap_px

    monkeypatch.setattr(auto, "OpenCLEvaluator", OffByOne)
    name, reason = auto.choose()
    assert name == "numpy"
    assert "counts a test scene differently from numpy (model pixels [" in reason


def test_the_choice_is_made_once_per_process(monkeypatch):
    class Usable:
        name = "opencl"

        @classmethod
        def unavailable(cls):
            return None

        def __init__(self, patch_scale):
            self.patch_scale = patch_scale

    checks = []
    monkeypatch.setattr(auto, "OpenCLEvaluator", Usable)
    monkeypatch.setattr(auto, "check_opencl", lambda: checks.append(1) or ("opencl", "fine"))
    assert [auto.auto_evaluator(s).patch_scale for s in (1.0, 2.0)] == [1.0, 2.0]
    assert checks == [1]


def test_the_test_scene_covers_the_image_border_and_the_foreground():
    body, camera, foreground, X = check_scene()
    with NumpyEvaluator() as ev:
        ev.setup(body, [camera], [foreground])
        model_px, overlap_px = ev.counts(X)
        image = ev.render(X[2], 0)
    assert (model_px > 0).all()
    assert (overlap_px < model_px).any()
    assert overlap_px.any()
    assert image[:, -1].any()  # the third pose reaches past the right border


def test_auto_is_the_default_and_the_summary_names_the_backend_that_ran(tiny_sequence, tmp_path):
    """A tracking run with the default config: evaluator_choice auto, backend the one chosen
    (what this process would choose: a fresh process chooses the same way)."""
    root = tmp_path / "data"
    root.mkdir()
    (root / "S1_walking").symlink_to(tiny_sequence)
    run_dir = tmp_path / "run"
    out = mmocap(*overrides(root, **{"tracking.frames": 1}), "overlays=0", f"hydra.run.dir={run_dir}", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    summary = json.loads((run_dir / "summary.json").read_text())
    expected, _ = auto.choose()
    assert (summary["evaluator_choice"], summary["backend"]) == ("auto", expected)
    assert f"({expected} backend)" in out.stdout
    assert f"evaluator=auto chose {expected}: " in out.stdout + out.stderr
