"""Multi-fidelity against exact search (mmocap.bench.fidelity): the table of both modes, and the
searches' syntax."""

import pandas as pd
import pytest
from omegaconf import OmegaConf

from mmocap.bench import fidelity
from mmocap.bench.output import PAGE_ORDER
from mmocap.config import compose
from tests.helpers import run_cli


def test_fidelity_puts_both_modes_side_by_side_with_ratios_to_exact_1500(tiny_sequence, tmp_path, monkeypatch):
    monkeypatch.setattr(
        fidelity,
        "FIDELITY_RUN",
        [
            "dataset=folder",
            f"dataset.root={tiny_sequence}",
            "evaluator=numpy",
            "body.vertices=1000",
            "recovery.enabled=false",
            "overlays=0",
            "progress=false",
            "foreground_cache=null",
        ],
    )
    assert (
        run_cli(
            "bench",
            "fidelity",
            "--exact",
            "100,1500",
            "--schedule",
            "0.5:1000:300+60",
            "--track-frames",
            "2",
            "--seeds",
            "0,1",
            "--out",
            tmp_path,
        )
        == 0
    )
    table = pd.read_csv(tmp_path / "fidelity.csv")
    assert table["mode"].tolist() == ["exact", "exact", "multi-fidelity (carried)"]
    assert table.cheap_evaluations.tolist() == [0, 0, 300]
    assert table.exact_evaluations.tolist() == [100, 1500, 60]
    reference = table.iloc[1]
    assert reference.error_ratio == 1
    assert reference.time_ratio == 1
    assert table.time_ratio.tolist() == pytest.approx((table.ms_per_frame / reference.ms_per_frame).tolist())
    assert table.mean_marker_error_mm.gt(0).all()
    assert table.ms_per_frame.gt(0).all()
    assert table.seeds.eq(2).all()
    assert table.error_sd_mm.ge(0).all()
    fastest, best = table.ms_per_frame.idxmin(), table.mean_marker_error_mm.idxmin()
    assert table.pareto[fastest]
    assert table.pareto[best]
    assert (tmp_path / "fidelity.png").read_bytes()[:4] == b"\x89PNG"
    assert list(tmp_path.iterdir())
    assert not [p for p in tmp_path.iterdir() if p.is_dir()]


def test_a_schedule_carries_a_population_size_for_the_whole_search_or_restarts_with_one_per_level():
    carried = fidelity.parse_schedule("0.25:1000:1400+400:28")
    assert (carried.carry, carried.popsize, carried.exact) == (True, 28, 400)
    assert carried.levels == [{"scale": 0.25, "vertices": 1000, "evaluations": 1400}]
    assert "optimizer.popsize=28" in carried.overrides(60, 1)
    assert "fidelity.carry=True" in carried.overrides(60, 1)
    restarted = fidelity.parse_schedule("0.25:3000:1200:28+300")
    assert (restarted.carry, restarted.popsize, restarted.mode) == (False, None, "multi-fidelity (restarted)")
    assert not any(o.startswith("optimizer.popsize") for o in restarted.overrides(60, 1))
    assert [(s.exact, s.popsize) for s in fidelity.parse_exact("1000, 1500:28")] == [(1000, None), (1500, 28)]


@pytest.mark.parametrize(
    "schedule",
    [
        "0.25:3000+300",
        "0.25:3000:1200",
        "2:3000:1200+300",
        "0.25:3000:1200+1",
        "0.25:3000:1200:28+300:28",
        "0.25:3000:1200+300:1",
    ],
)
def test_a_bad_schedule_is_one_line_naming_it(schedule, capsys):
    assert run_cli("bench", "fidelity", "--schedule", schedule) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "--schedule" in err or "fidelity.levels[0]" in err


@pytest.mark.parametrize("exact", ["1500:x", "1", ",", "1500:1"])
def test_a_bad_exact_search_is_one_line_naming_it(exact, capsys):
    assert run_cli("bench", "fidelity", "--exact", exact) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "--exact" in err


def test_canos_workload_tracks_seven_cameras_and_27393_vertices_on_the_same_run():
    demo = compose(fidelity.FIDELITY_RUN)
    cano = compose([*fidelity.FIDELITY_RUN, *fidelity.WORKLOADS["fidelity-cano"].overrides])
    assert list(demo.dataset.cameras) == ["C1", "C2", "C3", "BW1"]
    assert list(cano.dataset.cameras) == ["C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4"]
    assert (demo.body.vertices, cano.body.vertices) == (13695, 27393)
    assert OmegaConf.masked_copy(cano, ["realism", "tracking", "evaluator"]) == OmegaConf.masked_copy(
        demo, ["realism", "tracking", "evaluator"]
    )
    assert fidelity.WORKLOADS["fidelity-cano"].table in PAGE_ORDER
