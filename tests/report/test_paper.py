"""The papers' tables and figures from small hand-made runs/frames tables (the contract's
columns), with errors and fitness chosen so that every rank is known in advance, and so that
the two rank the algorithms differently."""

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from mmocap.errors import DataError, MmocapWarning
from mmocap.report import paper
from mmocap.report.results_page import page_section, sections
from tests.helpers import run_cli

SEQUENCES = ["S1_walking", "S1_boxing"]
SEEDS = [0, 1]
# base error (mm) per algorithm: the order every block ranks them in, but one (see below)
ALGORITHMS = {
    ("cmaes", "hierarchical"): 10.0,
    ("cmaes", "holistic"): 12.0,
    ("de", "holistic"): 15.0,
    ("apf", "holistic"): 30.0,
    ("psapf", "holistic"): 35.0,
}
SWAPPED_BLOCK = ("S1_boxing", 1)  # there holistic CMA-ES beats hierarchical CMA-ES
# base mean best fitness per algorithm: every block ranks them in this order, not the errors'
FITNESS = {
    ("de", "holistic"): 0.10,
    ("cmaes", "holistic"): 0.12,
    ("cmaes", "hierarchical"): 0.14,
    ("psapf", "holistic"): 0.20,
    ("apf", "holistic"): 0.25,
}


def run_error(optimizer, strategy, dof, evaluations, sequence, seed):
    """Base error, +2 mm at 28 DOF, -3 mm at 450 evaluations, +0.1 mm per seed."""
    error = ALGORITHMS[optimizer, strategy] + (2.0 if dof == 28 else 0.0) - (3.0 if evaluations == 450 else 0.0)
    if (sequence, seed) == SWAPPED_BLOCK and optimizer == "cmaes":
        error += 3.0 if strategy == "hierarchical" else -3.0
    return error + 0.1 * seed


def run_fitness(optimizer, strategy, dof, evaluations, seed, fitness=FITNESS):
    """Base fitness, -0.01 at 28 DOF (unlike the error), -0.02 at 450 evaluations, +0.001 per seed."""
    return (
        fitness[optimizer, strategy]
        - (0.01 if dof == 28 else 0.0)
        - (0.02 if evaluations == 450 else 0.0)
        + 0.001 * seed
    )


def make_sweep(
    vertices=(3000,), backends=("numpy",), algorithms=ALGORITHMS, dofs=(39, 28), settings=None, fitness=FITNESS
):
    """Runs and frames tables; ``settings``: the preset every run names (None: no such column)."""
    runs, frames = [], []
    for optimizer, strategy in algorithms:
        for dof in dofs:
            for evaluations in (150, 450):
                for v in vertices:
                    for backend in backends:
                        for sequence in SEQUENCES:
                            for seed in SEEDS:
                                error = run_error(optimizer, strategy, dof, evaluations, sequence, seed)
                                error += 5.0 * (v == 2000)
                                best = run_fitness(optimizer, strategy, dof, evaluations, seed, fitness)
                                run_id = f"{settings or 'r'}{len(runs):03d}"
                                per_frame = error + np.array([-1.0, 0.0, 1.0])
                                runs.append(
                                    dict(
                                        run_id=run_id,
                                        subject=sequence[:2],
                                        action=sequence[3:],
                                        sequence=sequence,
                                        seed=seed,
                                        optimizer=optimizer,
                                        strategy=strategy,
                                        algorithm=f"{optimizer}-{strategy}",
                                        dof=dof,
                                        evaluations=evaluations,
                                        vertices=v,
                                        backend=backend,
                                        frames=3,
                                        mean_marker_error_mm=error,
                                        mean_best_fitness=best,
                                        seconds_per_frame=evaluations * v / 1e6 * (0.1 if backend == "opencl" else 1.0),
                                        evaluation_seconds_per_frame=np.nan,
                                    )
                                )
                                frames += [
                                    dict(run_id=run_id, frame=f, marker_error_mm=e, fitness=best)
                                    for f, e in enumerate(per_frame)
                                ]
    runs = pd.DataFrame(runs)
    return (runs if settings is None else runs.assign(settings=settings)), pd.DataFrame(frames)


@pytest.fixture
def sweep(tmp_path):
    runs, frames = make_sweep()
    folder = tmp_path / "sweep"
    folder.mkdir()
    runs.to_csv(folder / "runs.csv", index=False)
    frames.to_csv(folder / "frames.csv", index=False)
    return folder


def read(path):
    return pd.read_csv(path, comment="#")


def test_table4_ranks_by_fitness_as_the_paper(sweep, tmp_path):
    out = tmp_path / "out"
    assert run_cli("paper", *["table4", str(sweep), "--out", str(out)]) == 0
    tables = out / "tables"
    assert (tables / "table4.csv").read_text().startswith("# mmocap ")  # provenance
    assert (tables / "table4.tex").read_text().startswith("% mmocap ")
    markdown = (tables / "table4.md").read_text()
    assert "ranked by mean best fitness" in markdown.splitlines()[0]
    assert markdown.splitlines()[2].startswith("_mmocap ")
    data = read(tables / "table4_data.csv")
    assert set(data.ranked_by) == {"mean_best_fitness"}
    assert data.settings.isna().all()
    # every block: DE, CMAES, H-CMAES, PSAPF, APF (the errors rank H-CMAES first, DE third)
    for evaluations in (150, 450):
        ranks = data[data.evaluations == evaluations].set_index("algorithm")["rank"]
        assert ranks.to_dict() == {
            f"{a}(39,{evaluations})": float(r) for r, a in enumerate(["DE", "CMAES", "H-CMAES", "PSAPF", "APF"], 1)
        }
    display = read(tables / "table4.csv")
    assert display["Algorithm (150 ev.)"].tolist()[:5] == [
        "DE(39,150)",
        "CMAES(39,150)",
        "H-CMAES(39,150)",
        "PSAPF(39,150)",
        "APF(39,150)",
    ]


def test_table4_ranks_the_marker_error_second(sweep, tmp_path):
    out = tmp_path / "out"
    assert run_cli("paper", *["table4", str(sweep), "--out", str(out)]) == 0
    tables = out / "tables"
    assert "ranked by mean marker error (mm)" in (tables / "table4_marker_error.md").read_text().splitlines()[0]
    data = read(out / "tables" / "table4_marker_error_data.csv")
    assert set(data.ranked_by) == {"mean_marker_error_mm"}
    assert set(data.dof) == {39}
    assert set(data.evaluations) == {150, 450}
    at150 = data[data.evaluations == 150].set_index("algorithm")
    # 4 blocks; H-CMAES first in 3, second in 1; CMAES the reverse; then DE, APF, PSAPF
    assert at150["rank"].to_dict() == {
        "H-CMAES(39,150)": 1.25,
        "CMAES(39,150)": 1.75,
        "DE(39,150)": 3.0,
        "APF(39,150)": 4.0,
        "PSAPF(39,150)": 5.0,
    }
    assert (at150.control == "H-CMAES(39,150)").all()
    assert (at150.n_blocks == 4).all()
    # chi2_F = 12N/(k(k+1)) (sum R^2 - k(k+1)^2/4) = 48/30 (54.625 - 45)
    assert at150.friedman_chi2.iloc[0] == pytest.approx(48 / 30 * 9.625)
    se = np.sqrt(5 * 6 / (6 * 4))
    assert at150.loc["PSAPF(39,150)", "z"] == pytest.approx(3.75 / se)
    assert at150["holm_alpha"].dropna().tolist() == pytest.approx([0.05, 0.025, 0.05 / 3, 0.0125])
    display = read(out / "tables" / "table4_marker_error.csv")
    assert display.columns[:3].tolist() == ["Algorithm (150 ev.)", "Rank (150 ev.)", "p-value (150 ev.)"]
    assert display["Algorithm (150 ev.)"].tolist()[-1] == "Fried. Stat."
    assert display["Holm"].tolist()[1:5] == [0.05, 0.025, 0.017, 0.013]
    assert display["p-value (450 ev.)"].iloc[0] == "-"
    significant = at150.dropna(subset=["p"])
    for label, row in significant.iterrows():  # the display marks exactly Holm's rejections
        shown = display.loc[display["Algorithm (150 ev.)"] == label, "p-value (150 ev.)"].item()
        assert shown.endswith("*") == row.significant
    assert r"\toprule" in (out / "tables" / "table4_marker_error.tex").read_text()


def test_table5_uses_28_dof_and_block_sequence_averages_seeds(sweep, tmp_path):
    out = tmp_path / "out"
    assert run_cli("paper", *["table5", str(sweep), "--out", str(out), "--block", "sequence"]) == 0
    data = read(out / "tables" / "table5_marker_error_data.csv")
    assert set(data.dof) == {28}
    assert (data.n_blocks == 2).all()
    at450 = data[data.evaluations == 450].set_index("algorithm")["rank"]
    # the seeds' means: H-CMAES 9.05 mm and CMAES 11.05 in S1_walking, but 10.55 and 9.55 in
    # S1_boxing (seed 1 swapped them): each first in one of the two blocks
    assert at450["H-CMAES(28,450)"] == 1.5
    assert at450["CMAES(28,450)"] == 1.5


def test_tables6_and_7_group_hierarchical_and_holistic(sweep, tmp_path):
    out = tmp_path / "out"
    assert run_cli("paper", *["table6", str(sweep), "--out", str(out)]) == 0
    assert run_cli("paper", *["table7", str(sweep), "--out", str(out)]) == 0
    six = read(out / "tables" / "table6_marker_error_data.csv")
    seven = read(out / "tables" / "table7_marker_error_data.csv")
    assert list(six.algorithm.unique()) == ["H-CMAES", "PSAPF"]  # PSAPF searches by parts
    assert list(seven.algorithm.unique()) == ["CMAES", "DE", "APF"]
    de = seven[seven.algorithm == "DE"]
    # every block's error: (39,450) < (28,450) < (39,150) < (28,150)
    assert de["rank"].tolist() == [1.0, 2.0, 3.0, 4.0]
    assert de["variant"].tolist() == ["DE(39,450)", "DE(28,450)", "DE(39,150)", "DE(28,150)"]
    # and its fitness: (28,450) < (39,450) < (28,150) < (39,150)
    de = read(out / "tables" / "table7_data.csv").query("algorithm == 'DE'")
    assert de["variant"].tolist() == ["DE(28,450)", "DE(39,450)", "DE(28,150)", "DE(39,150)"]
    assert de["rank"].tolist() == [1.0, 2.0, 3.0, 4.0]
    display = read(out / "tables" / "table7.csv")
    assert display.columns.tolist()[:3] == ["Algorithm (CMAES)", "Rank (CMAES)", "p-value (CMAES)"]
    assert (out / "tables" / "table6.md").is_file()


def test_each_settings_preset_is_ranked_apart_and_labelled(tmp_path):
    # the paper's settings rank DE first by fitness; mmocap's tuned ones APF (its fitness the lowest)
    tuned_fitness = {**FITNESS, ("apf", "holistic"): 0.05}
    paper_runs, paper_frames = make_sweep(settings="paper")
    tuned_runs, tuned_frames = make_sweep(settings="tuned", fitness=tuned_fitness)
    unnamed_runs, _ = make_sweep()
    folder = tmp_path / "sweep"
    folder.mkdir()
    pd.concat([tuned_runs, paper_runs, unnamed_runs]).to_csv(folder / "runs.csv", index=False)
    written, _ = paper.make(["table4"], folder, tmp_path / "out")
    tables = tmp_path / "out" / "tables"
    stems = [
        "table4_paper",
        "table4_paper_marker_error",
        "table4_tuned",
        "table4_tuned_marker_error",
        "table4",
        "table4_marker_error",
    ]  # the paper's first, the runs that name no preset last
    assert [p.name for p in written if p.suffix == ".md"] == [f"{stem}.md" for stem in stems]
    assert "Yeguas Table 4 (settings=paper): " in (tables / "table4_paper.md").read_text()
    assert "Yeguas Table 4 (settings=tuned): " in (tables / "table4_tuned_marker_error.md").read_text()
    first = {stem: read(tables / f"{stem}.csv")["Algorithm (150 ev.)"].iloc[0] for stem in stems}
    assert first == {
        "table4_paper": "DE(39,150)",
        "table4_tuned": "APF(39,150)",
        "table4": "DE(39,150)",
        **{f"{stem}_marker_error": "H-CMAES(39,150)" for stem in ("table4_paper", "table4_tuned", "table4")},
    }
    data = read(tables / "table4_tuned_data.csv")
    assert set(data.settings) == {"tuned"}
    assert (data.n_blocks == 4).all()


def test_each_realism_and_preset_is_ranked_apart_realistic_first(tmp_path):
    # exact data ranks APF first by fitness, realistic data DE
    exact_fitness = {**FITNESS, ("apf", "holistic"): 0.05}
    sweeps = [
        make_sweep(settings=settings, fitness=exact_fitness if realism == "exact" else FITNESS)[0].assign(
            realism=realism, run_id=lambda r, tag=f"{realism}-{settings}": tag + r.run_id
        )
        for realism in ("exact", "realistic")
        for settings in ("tuned", "paper")
    ]
    folder = tmp_path / "sweep"
    folder.mkdir()
    pd.concat(sweeps).to_csv(folder / "runs.csv", index=False)
    written, _ = paper.make(["table4"], folder, tmp_path / "out")
    stems = [f"table4_{realism}_{settings}" for realism in ("realistic", "exact") for settings in ("paper", "tuned")]
    assert [p.name for p in written if p.suffix == ".md" and "marker" not in p.name] == [f"{s}.md" for s in stems]
    tables = tmp_path / "out" / "tables"
    assert "Yeguas Table 4 (realism=exact, settings=tuned): " in (tables / "table4_exact_tuned.md").read_text()
    first = {stem: read(tables / f"{stem}.csv")["Algorithm (150 ev.)"].iloc[0] for stem in stems}
    assert first == {
        "table4_realistic_paper": "DE(39,150)",
        "table4_realistic_tuned": "DE(39,150)",
        "table4_exact_paper": "APF(39,150)",
        "table4_exact_tuned": "APF(39,150)",
    }
    data = read(tables / "table4_exact_paper_data.csv")
    assert set(data.realism) == {"exact"}
    assert set(data.settings) == {"paper"}
    assert (data.n_blocks == 4).all()


def test_cano_table3_values_and_ranks(tmp_path):
    runs, _ = make_sweep(vertices=(3000, 2000), algorithms={("cmaes", "holistic"): 12.0}, dofs=(39,))
    folder = tmp_path / "cano"
    folder.mkdir()
    runs.to_csv(folder / "runs.csv", index=False)
    assert run_cli("paper", *["cano_table3", str(folder), "--out", str(tmp_path / "out")]) == 0
    table = read(tmp_path / "out" / "tables" / "cano_table3.csv").set_index("Sequence")
    assert table.columns.tolist() == ["3000 v, 150 ev.", "3000 v, 450 ev.", "2000 v, 150 ev.", "2000 v, 450 ev."]
    # S1_walking, 3000 vertices, 150 evaluations: 12 mm, seeds 0 and 1 -> 12.05
    assert table.loc["S1_walking", "3000 v, 150 ev."] == pytest.approx(12.05)
    # S1_boxing seed 1 has CMA-ES 3 mm better: (12 + 9.1) / 2
    assert table.loc["S1_boxing", "3000 v, 150 ev."] == pytest.approx(10.55)
    assert table.loc["Avg. Error", "2000 v, 450 ev."] == pytest.approx(table.loc[SEQUENCES, "2000 v, 450 ev."].mean())
    assert table.loc["Ranks"].tolist() == [2.0, 1.0, 4.0, 3.0]


def test_cano_table3_needs_one_algorithm(sweep, tmp_path):
    with pytest.raises(DataError, match="compares the mesh levels and budgets of one algorithm and DOF"):
        paper.make(["cano_table3"], sweep, tmp_path)


def test_fig4_front_and_table(tmp_path):
    runs, _ = make_sweep(
        vertices=(3000, 2000), backends=("numpy", "opencl"), algorithms={("cmaes", "holistic"): 12.0}, dofs=(39,)
    )
    folder = tmp_path / "fig4"
    folder.mkdir()
    runs.to_csv(folder / "runs.csv", index=False)
    written, _ = paper.make(["fig4"], folder, tmp_path / "out")
    png = tmp_path / "out" / "figures" / "fig4.png"
    assert png in written
    assert Image.open(png).size[0] > 500
    assert Image.open(png).info["Description"].startswith("mmocap ")
    table = read(tmp_path / "out" / "tables" / "fig4.csv")
    front = table[table.pareto]
    # opencl 3000 v is the fastest at each budget and 2000 v is 5 mm worse: it is dominated
    assert sorted(zip(front.backend, front.vertices, front.evaluations)) == [
        ("opencl", 2000, 150),
        ("opencl", 3000, 150),
        ("opencl", 3000, 450),
    ]


def test_figures_7_and_10(sweep, tmp_path):
    written, skipped = paper.make(["fig7", "fig10"], sweep, tmp_path / "out")
    assert not skipped
    for name in ("fig7", "fig10"):
        path = tmp_path / "out" / "figures" / f"{name}.png"
        assert path in written
        image = np.asarray(Image.open(path).convert("L"))
        assert image.shape[0] > 300
        assert image.std() > 10


def test_figures_and_cano_table3_are_made_per_variant(tmp_path):
    # the exact runs are 4 mm better than the realistic ones, frame by frame
    variants = []
    for realism, shift in (("exact", -4.0), ("realistic", 0.0)):
        runs, frames = make_sweep(vertices=(3000, 2000), algorithms={("cmaes", "holistic"): 12.0}, dofs=(39,))
        tag = realism[0]
        variants.append(
            (
                runs.assign(
                    realism=realism, run_id=tag + runs.run_id, mean_marker_error_mm=runs.mean_marker_error_mm + shift
                ),
                frames.assign(run_id=tag + frames.run_id, marker_error_mm=frames.marker_error_mm + shift),
            )
        )
    folder = tmp_path / "sweep"
    folder.mkdir()
    pd.concat([r for r, _ in variants]).to_csv(folder / "runs.csv", index=False)
    pd.concat([f for _, f in variants]).to_csv(folder / "frames.csv", index=False)
    written, skipped = paper.make(["cano_table3", "fig4", "fig7", "fig10"], folder, tmp_path / "out")
    assert not skipped
    names = {p.name for p in written}
    for realism in ("realistic", "exact"):
        assert {
            f"cano_table3_{realism}.md",
            f"fig4_{realism}.png",
            f"fig7_{realism}.png",
            f"fig10_{realism}.png",
        } <= names
    tables = tmp_path / "out" / "tables"
    cano = {r: read(tables / f"cano_table3_{r}.csv").set_index("Sequence") for r in ("realistic", "exact")}
    assert cano["realistic"].loc["S1_walking", "3000 v, 150 ev."] == pytest.approx(12.05)
    assert cano["exact"].loc["S1_walking", "3000 v, 150 ev."] == pytest.approx(8.05)
    assert "(realism=exact)" in (tables / "cano_table3_exact.md").read_text()
    front = read(tables / "fig4_exact.csv")
    assert front.runs.sum() == len(variants[0][0])  # the exact runs alone
    assert front.mean_marker_error_mm.min() == pytest.approx(
        variants[0][0].mean_marker_error_mm.groupby([variants[0][0].vertices, variants[0][0].evaluations]).mean().min()
    )


def test_fig10_needs_the_frames(sweep, tmp_path):
    (sweep / "frames.csv").unlink()
    with pytest.raises(DataError, match="no frames.csv beside the runs"):
        paper.make(["fig10"], sweep, tmp_path)


def test_frames_of_unknown_runs_are_an_error(sweep, tmp_path):
    frames = read(sweep / "frames.csv")
    frames.loc[0, "run_id"] = "ghost"
    frames.to_csv(sweep / "frames.csv", index=False)
    with pytest.raises(DataError, match="frames of 1 run.s. not in runs.csv, e.g. 'ghost'"):
        paper.make(["fig7"], sweep, tmp_path)


def test_all_makes_what_it_can_and_names_the_rest(sweep, tmp_path, capsys):
    assert run_cli("paper", *["all", str(sweep), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "skipped cano_table3: " in out
    for name in ("table4", "table5", "table6", "table7"):
        assert (tmp_path / "out" / "tables" / f"{name}.md").is_file()
        assert (tmp_path / "out" / "tables" / f"{name}_marker_error.md").is_file()


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda runs: runs.drop(columns="dof"), "missing column(s) 'dof'"),
        (lambda runs: runs[runs.dof == 28], "no runs with dof = 39 for table4"),
        (
            lambda runs: runs[runs.optimizer == "cmaes"],
            "table4 at 39 DOF and 150 evaluations: the Friedman test needs at least 3 values of 'algorithm', "
            "got 2: CMAES(39,150), H-CMAES(39,150)",
        ),
        (
            lambda runs: runs.assign(mean_marker_error_mm=runs.mean_marker_error_mm.where(runs.index != 0, np.nan)),
            "table4_marker_error at 39 DOF and 150 evaluations: column 'mean_marker_error_mm' holds 1 NaN or infinite",
        ),
        (
            lambda runs: runs.assign(mean_best_fitness=runs.mean_best_fitness.where(runs.index != 0, np.nan)),
            "table4 at 39 DOF and 150 evaluations: column 'mean_best_fitness' holds 1 NaN or infinite",
        ),
        (lambda runs: runs.drop(columns="mean_best_fitness"), "missing column(s) 'mean_best_fitness'"),
    ],
)
def test_bad_runs_exit_2_with_one_line(sweep, tmp_path, capsys, damage, message):
    runs = damage(read(sweep / "runs.csv"))
    runs.to_csv(sweep / "runs.csv", index=False)
    assert run_cli("paper", *["table4", str(sweep), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"mmocap: error: {sweep / 'runs.csv'}")
    assert message in err
    assert err.count("\n") == 1


def test_missing_folder(tmp_path, capsys):
    assert run_cli("paper", *["fig4", str(tmp_path / "nope")]) == 2
    assert capsys.readouterr().err == f"mmocap: error: {tmp_path / 'nope'}: no such folder\n"


def test_runs_csv_columns_are_checked_for_what_each_table_uses(sweep, tmp_path):
    runs = read(sweep / "runs.csv")
    runs.loc[3, "evaluations"] = np.nan  # a groupby would drop this run silently
    runs.to_csv(sweep / "runs.csv", index=False)
    with pytest.raises(
        DataError,
        match=r"runs.csv: column 'evaluations' has 1 empty cell\(s\), the first in "
        r"data row 4",
    ):
        paper.make(["table4"], sweep, tmp_path)
    runs = runs.astype({"evaluations": object})
    runs.loc[3, "evaluations"] = "150 ev."
    runs.to_csv(sweep / "runs.csv", index=False)
    with pytest.raises(
        DataError,
        match="column 'evaluations' must hold whole numbers; 1 cell.s. do not, the first '150 ev.' in data row 4",
    ):
        paper.make(["table4"], sweep, tmp_path)


def test_whole_number_columns_read_as_floats_label_as_integers(sweep, tmp_path):
    runs = read(sweep / "runs.csv")
    runs.assign(dof=runs.dof.astype(float)).to_csv(sweep / "runs.csv", index=False)  # 39.0, as pandas writes them
    paper.make(["table4"], sweep, tmp_path)
    assert "CMAES(39,150)" in (tmp_path / "tables" / "table4.md").read_text()


def test_frames_without_ground_truth_are_left_out_with_a_warning(sweep, tmp_path):
    frames = read(sweep / "frames.csv")
    frames.loc[[0, 1], "marker_error_mm"] = np.nan
    frames.to_csv(sweep / "frames.csv", index=False)
    with pytest.warns(MmocapWarning, match=r"frames.csv: 2 of \d+ frame\(s\), of 1 run\(s\), have no marker error"):
        data = paper.frame_errors(read(sweep / "runs.csv"), frames, str(sweep / "runs.csv"))
    assert len(data) == len(frames) - 2
    assert data["marker_error_mm"].notna().all()
    frames.loc[0, "marker_error_mm"] = np.inf
    with pytest.raises(DataError, match=r"frames.csv: column 'marker_error_mm' holds 1 infinite value"):
        paper.frame_errors(read(sweep / "runs.csv"), frames, str(sweep / "runs.csv"))


def test_seeds_that_are_not_numbers_are_described_as_they_are():
    runs = pd.DataFrame({"seed": ["a", "b", "a"]})
    assert paper.describe_runs(runs, "runs.csv") == "runs.csv (3 runs; seeds a, b)"
    assert paper.describe_runs(pd.DataFrame({"seed": [0, 1, 2, 3]}), "r") == "r (4 runs; seeds 0-3)"


def test_alpha_outside_0_1_is_named(sweep, tmp_path, capsys):
    assert run_cli("paper", "table4", sweep, "--out", tmp_path / "out", "--alpha", "1.5") == 2
    assert capsys.readouterr().err == "mmocap: error: --alpha must be a number in (0, 1), got 1.5\n"


def test_a_table_goes_on_its_results_page_with_page(sweep, tmp_path):
    page = tmp_path / "docs" / "results" / "table4.md"
    args = ["table4", str(sweep), "--out", str(tmp_path / "out"), "--page", str(page), "--target", "table4 SCALE=x"]
    assert run_cli("paper", *args) == 0
    text = page.read_text()
    assert text.startswith("Generated by `make table4 SCALE=x` on ")
    table = (tmp_path / "out" / "tables" / "table4.md").read_text()
    assert sections(text)["table4"] == page_section(table)  # the stamp says when and where
    assert page_section(table).startswith("Yeguas Table 4")
    assert "_mmocap" not in page_section(table)
