"""The evaluator benchmark (mmocap.bench) end to end on a tiny setting."""
import time

import numpy as np
import pandas as pd
import pytest

from mmocap import bench
from tests.helpers import run_cli


def test_bench_writes_both_tables_with_speedups_against_naive(tmp_path, capsys):
    assert run_cli("bench", *["all", "--backends", "naive,numpy", "--vertices", "2000", "--budgets", "60",
                "--cameras", "2", "--population", "4", "--repeats", "1", "--out", str(tmp_path),
                "--prefix", "t_"]) == 0
    t2 = pd.read_csv(tmp_path / "t_table2.csv")
    assert list(t2.backend) == ["naive", "numpy"] and (t2.us_per_model_view > 0).all()
    assert t2.speedup_vs_naive.iloc[0] == 1.0
    t1 = pd.read_csv(tmp_path / "t_table1.csv")
    naive, numpy = t1.iloc[0], t1.iloc[1]
    assert naive.extrapolated and not numpy.extrapolated
    assert naive.frame_ms == pytest.approx(60 * 2 * t2.us_per_model_view.iloc[0] / 1e3)
    assert 0 < numpy.solutions_ms <= numpy.frame_ms
    assert numpy.fps == pytest.approx(1e3 / numpy.frame_ms)
    assert numpy.host_share == pytest.approx(1 - numpy.solutions_ms / numpy.frame_ms) and 0 <= numpy.host_share < 1
    assert (tmp_path / "t_table1.md").read_text().startswith("# Time per frame")
    assert (tmp_path / "t_fig3.png").read_bytes()[:4] == b"\x89PNG"
    assert "| numpy" in capsys.readouterr().out


def test_roofline_puts_the_kernel_beside_the_floor_of_the_measured_rates(tmp_path):
    pytest.importorskip("pyopencl")
    assert run_cli("bench", "roofline", "--backends", "opencl", "--vertices", "1000", "--population", "4",
                   "--repeats", "1", "--out", str(tmp_path)) == 0
    table = pd.read_csv(tmp_path / "roofline.csv")
    needs, floor, kernel = table.iloc[:3], table.iloc[3], table.iloc[4]
    assert floor.us_per_model_view == needs.us_per_model_view.max() and floor.ratio_to_floor == 1
    assert kernel.us_per_model_view > 0
    assert kernel.ratio_to_floor == pytest.approx(kernel.us_per_model_view / floor.us_per_model_view)
    assert "500 ORs" in needs.need_per_model_view.iloc[2]  # half of 1000 vertices face the camera


def test_roofline_needs_the_opencl_backend(capsys):
    assert run_cli("bench", "roofline", "--backends", "numpy") == 2
    assert "roofline needs the opencl backend" in capsys.readouterr().err


def test_bench_rejects_an_unknown_backend(capsys):
    assert run_cli("bench", "table2", "--backends", "numpy,warp-drive") == 2
    assert "unknown backend(s) warp-drive" in capsys.readouterr().err


class CountingEvaluator:
    """A stand-in evaluator that counts its calls; each call takes ``delay`` seconds."""

    def __init__(self, delay: float):
        self.delay, self.calls = delay, 0

    def setup(self, body, cameras, foreground):
        pass

    def __call__(self, X):
        self.calls += 1
        time.sleep(self.delay)
        return np.random.default_rng(self.calls).random(len(X))


@pytest.fixture(scope="module")
def small_scene():
    return bench.Scene(2000, cameras=1)


@pytest.mark.parametrize("delay, frames, seconds, expected", [
    (0.0, 1, 0.0, 1),      # no time budget: the frames asked for
    (0.0, 2, 10.0, 5),     # fast frames: more, up to MAX_FRAMES
    (0.02, 1, 0.1, 1),     # a frame of 10 calls takes 0.2 s: no second one within 0.1 s
    (0.02, 3, 0.1, 3),     # but never fewer than asked for
])
def test_frame_ms_adds_frames_that_fit_in_the_time_given(small_scene, delay, frames, seconds,
                                                         expected):
    ev = CountingEvaluator(delay)
    bench.frame_ms(ev, small_scene, 140, frames, seconds)
    # the warm-up call, then per frame the start pose and CMA-ES's 10 calls (139 evaluations)
    assert ev.calls == 1 + expected * (1 + 10)


def test_fidelity_puts_both_modes_side_by_side_with_ratios_to_exact_1500(tiny_sequence, tmp_path, monkeypatch):
    monkeypatch.setattr(bench, "FIDELITY_RUN", ["dataset=folder", f"dataset.root={tiny_sequence}", "evaluator=numpy",
                                                "body.vertices=1000", "recovery.enabled=false", "overlays=0",
                                                "progress=false", "foreground_cache=null"])
    assert run_cli("bench", "fidelity", "--exact", "100,1500", "--schedule", "0.5:1000:300+60",
                   "--track-frames", "2", "--seeds", "0,1", "--out", tmp_path) == 0
    table = pd.read_csv(tmp_path / "fidelity.csv")
    assert table["mode"].tolist() == ["exact", "exact", "multi-fidelity (carried)"]
    assert table.cheap_evaluations.tolist() == [0, 0, 300] and table.exact_evaluations.tolist() == [100, 1500, 60]
    reference = table.iloc[1]
    assert reference.error_ratio == 1 and reference.time_ratio == 1
    assert table.time_ratio.tolist() == pytest.approx((table.ms_per_frame / reference.ms_per_frame).tolist())
    assert table.mean_marker_error_mm.gt(0).all() and table.ms_per_frame.gt(0).all()
    assert table.seeds.eq(2).all() and table.error_sd_mm.ge(0).all()
    fastest, best = table.ms_per_frame.idxmin(), table.mean_marker_error_mm.idxmin()
    assert table.pareto[fastest] and table.pareto[best]
    assert (tmp_path / "fidelity.png").read_bytes()[:4] == b"\x89PNG"
    assert list(tmp_path.iterdir()) and not [p for p in tmp_path.iterdir() if p.is_dir()]  # the runs' folders go


def test_a_schedule_carries_a_population_size_for_the_whole_search_or_restarts_with_one_per_level():
    carried = bench.parse_schedule("0.25:1000:1400+400:28")
    assert (carried.carry, carried.popsize, carried.exact) == (True, 28, 400)
    assert carried.levels == [{"scale": 0.25, "vertices": 1000, "evaluations": 1400}]
    assert "optimizer.popsize=28" in carried.overrides(60, 1) and "fidelity.carry=True" in carried.overrides(60, 1)
    restarted = bench.parse_schedule("0.25:3000:1200:28+300")
    assert (restarted.carry, restarted.popsize, restarted.mode) == (False, None, "multi-fidelity (restarted)")
    assert not any(o.startswith("optimizer.popsize") for o in restarted.overrides(60, 1))
    assert [(s.exact, s.popsize) for s in bench.parse_exact("1000, 1500:28")] == [(1000, None), (1500, 28)]


@pytest.mark.parametrize("schedule", ["0.25:3000+300", "0.25:3000:1200", "2:3000:1200+300", "0.25:3000:1200+1",
                                      "0.25:3000:1200:28+300:28", "0.25:3000:1200+300:1"])
def test_a_bad_schedule_is_one_line_naming_it(schedule, capsys):
    assert run_cli("bench", "fidelity", "--schedule", schedule) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ("--schedule" in err or "fidelity.levels[0]" in err)


@pytest.mark.parametrize("exact", ["1500:x", "1", ",", "1500:1"])
def test_a_bad_exact_search_is_one_line_naming_it(exact, capsys):
    assert run_cli("bench", "fidelity", "--exact", exact) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--exact" in err
