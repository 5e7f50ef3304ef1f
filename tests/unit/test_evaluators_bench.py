"""The evaluator benchmark (mmocap.bench) end to end on a tiny setting."""
import pandas as pd
import pytest

from mmocap import bench


def test_bench_writes_both_tables_with_speedups_against_naive(tmp_path, capsys):
    bench.main(["all", "--backends", "naive,numpy", "--vertices", "2000", "--budgets", "60",
                "--cameras", "2", "--population", "4", "--repeats", "1", "--out", str(tmp_path),
                "--prefix", "t_"])
    t2 = pd.read_csv(tmp_path / "t_table2.csv")
    assert list(t2.backend) == ["naive", "numpy"] and (t2.us_per_model_view > 0).all()
    assert t2.speedup_vs_naive.iloc[0] == 1.0
    t1 = pd.read_csv(tmp_path / "t_table1.csv")
    naive, numpy = t1.iloc[0], t1.iloc[1]
    assert naive.extrapolated and not numpy.extrapolated
    assert naive.frame_ms == pytest.approx(60 * 2 * t2.us_per_model_view.iloc[0] / 1e3)
    assert 0 < numpy.solutions_ms <= numpy.frame_ms
    assert numpy.fps == pytest.approx(1e3 / numpy.frame_ms)
    assert (tmp_path / "t_table1.md").read_text().startswith("# Time per frame")
    assert (tmp_path / "t_fig3.png").read_bytes()[:4] == b"\x89PNG"
    assert "| numpy" in capsys.readouterr().out


def test_bench_rejects_an_unknown_backend(capsys):
    with pytest.raises(SystemExit):
        bench.main(["table2", "--backends", "numpy,warp-drive"])
    assert "unknown backend(s) warp-drive" in capsys.readouterr().err
