"""The papers' tables and figures from the runs of a sweep.

``python -m mmocap.report.paper NAME FOLDER`` reads ``FOLDER/runs.csv`` (one row per
finished run) and, for the figures that plot frames, ``FOLDER/frames.csv`` (one row per
tracked frame), and writes ``outputs/tables/NAME.{csv,md,tex}`` and
``outputs/figures/NAME.png``. NAME is one of:

- ``table4``, ``table5``: Yeguas Tables 4 and 5, the algorithms ranked at 39 and 28 DOF, one
  Friedman test and Holm comparisons against the best-ranked per budget;
- ``table6``, ``table7``: Yeguas Tables 6 and 7, for each hierarchical (Table 6: H-CMAES,
  H-DE, H-PSO and the partitioned PSAPF) or holistic (Table 7) algorithm, its DOF x budget
  variants ranked against each other;
- ``fig7``: Yeguas Fig. 7, box plots of the marker error of every frame per sequence and
  algorithm-DOF pair, one panel per budget and strategy;
- ``fig10``: Yeguas Fig. 10, error per frame of the holistic algorithms on one sequence;
- ``cano_table3``: Cano Table 3, error per sequence of each mesh level x budget, with the
  average and the Friedman ranks of the configurations;
- ``fig4``: Cano Fig. 4, time per frame against error of each mesh level x budget x
  backend, the non-dominated configurations linked (also written as a table);
- ``autostart``: the automatic start against the true first pose and body, per sequence;
- ``keypoint_weight``: the mean marker error per realism level and keypoint term weight
  (silhouettes only at weight 0), against the goals of :data:`KEYPOINT_GOALS_MM`;
- ``all``: every one of them that the runs allow; the others are named with the reason.

Algorithms are written as in the Yeguas paper: ``H-`` for a hierarchical search, then
``ALG(DOF,EVAL)``. A Friedman block is a (sequence, seed) pair by default, each run its own
measurement; ``--block sequence`` averages the seeds of a sequence first, as the paper's
tables do (9 blocks). Tables 4-7 mark with ``*`` the p-values that Holm's procedure finds
significant, and write every statistic in ``<table>_data.csv``. Errors in mm, times in s.

Tables 4-7 rank what the paper ranks (Sec. 5.4: "the averaged position of its best
solutions' fitness"): ``mean_best_fitness``, each frame's best silhouette fitness (Eq. 5, in
[0, 1], 0 = perfect) averaged over the run's frames, in ``NAME.*``; the ranking of the mean
marker error follows in ``NAME_marker_error.*`` (:data:`RANKINGS`). The runs of each
variant are ranked apart: the data's realism (column ``realism``: ``realistic`` or ``exact``,
``conf/realism/``) and the optimiser settings preset (column ``settings``: ``paper``, Yeguas
Table 3, and ``tuned``, mmocap's defaults; ``conf/settings/``), their files named
``NAME_<realism>_<settings>``, e.g. ``table4_realistic_paper.md`` and
``table4_exact_tuned_marker_error.md``. The figures and Cano's table are made per variant
too (``fig7_realistic_paper.png``, ``cano_table3_exact.md``); a sweep without these columns
(real data) writes ``NAME`` alone.
"""

from __future__ import annotations

import argparse
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from mmocap.analysis import figures
from mmocap.analysis.pareto import summarise
from mmocap.analysis.statistics import (
    FriedmanHolm,
    finite_numbers,
    friedman_holm,
    no_empty_cells,
    overflow_free_mean,
    read_table,
    require_columns,
    whole_numbers,
)
from mmocap.analysis.tables import format_p, provenance, write_csv, write_table
from mmocap.errors import DataError, MmocapWarning
from mmocap.report.results_page import page_section, update_page
from mmocap.validate import check_number

ERROR = "mean_marker_error_mm"
FITNESS = "mean_best_fitness"
#: what Tables 4-7 rank, the main table first: column -> (file-name suffix, words of the title).
#: The paper ranks "the averaged position of its best solutions' fitness" (Yeguas Sec. 5.4).
RANKINGS = {
    FITNESS: ("", "mean best fitness (Eq. 5, 0 = perfect), as the paper ranks"),
    ERROR: ("_marker_error", "mean marker error (mm)"),
}
OPTIMIZER_ORDER = ["cmaes", "de", "pso", "apf", "psapf"]
DEFAULT_BLOCK = ("sequence", "seed")
#: columns of runs.csv that are whole numbers (they name, group and label runs)
WHOLE_NUMBER_COLUMNS = ("seed", "dof", "evaluations", "vertices")
Outputs = list[Path]


def short_name(optimizer: str, strategy: str) -> str:
    """'cmaes', 'hierarchical' -> 'H-CMAES'; 'apf', 'holistic' -> 'APF'."""
    return ("H-" if strategy == "hierarchical" else "") + optimizer.upper()


def paper_label(optimizer: str, strategy: str, dof: int, evaluations: int) -> str:
    """The Yeguas paper's ALG(DOF,EVAL), e.g. 'H-CMAES(39,500)'."""
    return f"{short_name(optimizer, strategy)}({dof},{evaluations})"


def is_hierarchical(runs: pd.DataFrame) -> pd.Series:
    """Rows searched by parts: a hierarchical strategy, or the partitioned PSAPF (Table 6)."""
    return (runs["strategy"] == "hierarchical") | (runs["optimizer"] == "psapf")


def by_optimizer(pairs) -> list[tuple[str, str]]:
    """(optimizer, strategy) pairs in the papers' order: CMA-ES, DE, PSO, APF, PSAPF, then
    others by name; holistic before hierarchical."""
    rank = {name: i for i, name in enumerate(OPTIMIZER_ORDER)}
    return sorted(set(pairs), key=lambda p: (rank.get(p[0], len(rank)), p[0], p[1] == "hierarchical"))


def describe_runs(runs: pd.DataFrame, source: str) -> str:
    """The source of a table or figure: its file, how many runs, their seeds and commits."""
    parts = [f"{len(runs)} runs"]
    if "seed" in runs and not runs.empty:
        numbers = pd.to_numeric(runs["seed"], errors="coerce")
        if (numbers % 1 == 0).all():  # whole numbers (NaN fails): a range where they are contiguous
            seeds = sorted({int(s) for s in numbers})
            contiguous = len(seeds) > 2 and seeds == list(range(seeds[0], seeds[-1] + 1))
            parts.append(f"seeds {seeds[0]}-{seeds[-1]}" if contiguous else f"seeds {', '.join(map(str, seeds))}")
        else:
            parts.append(f"seeds {', '.join(sorted(map(str, runs['seed'].unique())))}")
    if "git_commit" in runs:
        commits = sorted({str(c)[:10] for c in runs["git_commit"].dropna()})
        if commits:
            parts.append(f"run commit(s) {', '.join(commits)}")
    return f"{source} ({'; '.join(parts)})"


def checked(runs: pd.DataFrame, columns: list[str], source: str) -> pd.DataFrame:
    """``runs`` after checking the ``columns`` a table or figure needs: present, without empty
    cells, and those of :data:`WHOLE_NUMBER_COLUMNS` whole numbers (returned as int). The
    measured columns (:data:`RANKINGS`) are left to the statistics, which name their bad values."""
    require_columns(runs, columns, source)
    no_empty_cells(runs, [c for c in columns if c not in RANKINGS], source)
    return runs.assign(**{c: whole_numbers(runs, c, source) for c in columns if c in WHOLE_NUMBER_COLUMNS})


#: the columns of runs.csv whose values are ranked apart (a run's variant), in file-name order,
#: each with the value that comes first: the realism of the data, then the optimiser settings
VARIANT_COLUMNS = {"realism": "realistic", "settings": "paper"}


def variants(runs: pd.DataFrame) -> list[tuple[dict, pd.DataFrame]]:
    """The runs of each variant: each combination of the :data:`VARIANT_COLUMNS` values
    present (``realistic`` data before the others, ``paper`` settings before the others, then
    by name), as ``({column: value}, runs)``; a column missing from runs.csv, or an empty cell,
    is left out of the variant (runs that name no settings preset, a real dataset)."""
    present = [c for c in VARIANT_COLUMNS if c in runs]
    if not present:
        return [({}, runs)]
    cells = runs[present].astype(object).where(runs[present].notna(), None)
    keys = {tuple(row) for row in cells.itertuples(index=False)}

    def order(key):
        return [(value is None, value != VARIANT_COLUMNS[c], str(value)) for c, value in zip(present, key)]

    out = []
    for key in sorted(keys, key=order):
        chosen = np.ones(len(runs), bool)
        for column, value in zip(present, key):
            chosen &= (cells[column] == value).to_numpy() if value is not None else cells[column].isna().to_numpy()
        out.append(({c: v for c, v in zip(present, key) if v is not None}, runs[chosen]))
    return out


def variant_stem(name: str, variant: dict) -> str:
    """The file name of a table or figure of one variant: 'fig7', {'realism': 'realistic',
    'settings': 'paper'} -> 'fig7_realistic_paper'; 'fig7', {} -> 'fig7'."""
    return "_".join([name, *variant.values()])


def table_stem(name: str, variant: dict, value: str) -> str:
    """The file name of a ranking table: 'table4', {'realism': 'realistic', 'settings':
    'paper'}, FITNESS -> 'table4_realistic_paper'; 'table4', {'settings': 'tuned'}, ERROR ->
    'table4_tuned_marker_error'."""
    return variant_stem(name, variant) + RANKINGS[value][0]


def variant_words(variant: dict) -> str:
    """' (realism=realistic, settings=paper)', or '' for no variant."""
    return f" ({', '.join(f'{k}={v}' for k, v in variant.items())})" if variant else ""


def _mark(p: float, significant: bool) -> str:
    return "-" if np.isnan(p) else format_p(p) + ("*" if significant else "")


def _ranking_groups(tests: list[tuple[str, FriedmanHolm]], alpha: float) -> pd.DataFrame:
    """Side-by-side Algorithm | Rank | p-value groups, one per test, the Friedman statistic
    as a last row and Holm's alpha / (r - 1) as a last column (the Yeguas tables' shape)."""
    blocks = []
    for name, test in tests:
        c = test.comparisons
        group = pd.DataFrame(
            {
                f"Algorithm ({name})": c["algorithm"],
                f"Rank ({name})": c["rank"].map(lambda r: f"{r:.3f}"),
                f"p-value ({name})": [_mark(p, s) for p, s in zip(c["p"], c["significant"])],
            }
        )
        friedman = pd.DataFrame(
            {
                group.columns[0]: ["Fried. Stat."],
                group.columns[1]: [f"{test.statistic:.3f}"],
                group.columns[2]: [f"p = {format_p(test.p_value)}"],
            }
        )
        blocks.append(pd.concat([group, friedman], ignore_index=True))
    table = pd.concat(blocks, axis=1).fillna("")
    k = max(t.n_algorithms for _, t in tests)
    table["Holm"] = [""] + [f"{alpha / (r - 1):.3f}" for r in range(2, k + 1)] + [""] * (len(table) - k)
    return table


def _long_statistics(tests: list[tuple[dict, FriedmanHolm]], compared: str = "algorithm") -> pd.DataFrame:
    """Every statistic of every test, one row per compared item (column ``compared``), keyed
    by the test's fields."""
    rows = []
    for keys, test in tests:
        rows.append(
            test.comparisons.rename(columns={"algorithm": compared}).assign(
                **keys,
                n_algorithms=test.n_algorithms,
                n_blocks=test.n_blocks,
                friedman_chi2=test.statistic,
                friedman_p=test.p_value,
                iman_davenport=test.iman_davenport,
                iman_davenport_p=test.iman_davenport_p,
                control=test.control,
            )
        )
    table = pd.concat(rows, ignore_index=True)
    front = list(tests[0][0])
    return table[front + [c for c in table.columns if c not in front]]


def _test(
    runs: pd.DataFrame, labels, value: str, block, alpha: float, source: str, what: str, compared: str = "algorithm"
) -> FriedmanHolm:
    """Friedman and Holm of the column ``value`` on ``runs`` with ``labels`` as the compared
    column, named ``compared`` in messages, which start with '<source>, <what>: '."""
    return friedman_holm(
        runs.assign(**{compared: list(labels)}), list(block), compared, value, alpha=alpha, source=f"{source}, {what}"
    )


def _write_rankings(
    runs: pd.DataFrame,
    out: Path,
    name: str,
    variant: dict,
    value: str,
    caption: str,
    tests: list[tuple[dict, FriedmanHolm]],
    headers: list[str],
    compared: str,
    block,
    alpha: float,
    source: str,
) -> Outputs:
    """Write a Yeguas-shaped table of ``tests`` (one group per header) and its data CSV, named
    by :func:`table_stem`."""
    n = sorted({t.n_blocks for _, t in tests})
    title = (
        f"Yeguas Table {name[-1]}"
        + variant_words(variant)
        + f": {caption}, ranked by {RANKINGS[value][1]}. Friedman ranks over {'/'.join(map(str, n))} "
        f"blocks ({' x '.join(block)}), the lowest ranked first; p: Holm vs the best-ranked, "
        f"* significant at alpha = {alpha:g}"
    )
    display = _ranking_groups([(h, t) for h, (_, t) in zip(headers, tests)], alpha)
    data = _long_statistics(tests, compared)
    data.insert(0, "ranked_by", value)
    for column in reversed(VARIANT_COLUMNS):
        data.insert(0, column, variant.get(column))
    origin = describe_runs(runs, source)
    stem = out / "tables" / table_stem(name, variant, value)
    return write_table(display, stem, title=title, source=origin) + [
        write_csv(data, stem.with_name(f"{stem.name}_data.csv"), origin)
    ]


def _each_variant(build: Callable[..., Outputs], runs: pd.DataFrame, out: Path, **options) -> Outputs:
    """``build`` on the runs of each variant (:func:`variants`), once for each ranking of
    :data:`RANKINGS`."""
    return [
        path
        for variant, group in variants(runs)
        for value in RANKINGS
        for path in build(group, out, variant=variant, value=value, **options)
    ]


def yeguas_rankings(
    runs: pd.DataFrame,
    out: Path,
    *,
    name: str,
    dof: int,
    value: str,
    variant: dict,
    block=DEFAULT_BLOCK,
    alpha: float = 0.05,
    source: str = "runs",
) -> Outputs:
    """Yeguas Table 4 (dof 39) or 5 (dof 28) of the runs of one variant (:func:`variants`):
    the algorithms ranked by the column ``value`` (one of :data:`RANKINGS`) at each budget."""
    runs = checked(runs, ["optimizer", "strategy", "dof", "evaluations", value, *block], source)
    stem = table_stem(name, variant, value)
    runs = runs[runs["dof"] == dof]
    if runs.empty:
        raise DataError(f"{source}: no runs with dof = {dof} for {stem}")
    tests = []
    for evaluations, group in runs.groupby("evaluations"):
        labels = [paper_label(o, s, dof, evaluations) for o, s in zip(group.optimizer, group.strategy)]
        tests.append(
            (
                {"dof": dof, "evaluations": evaluations},
                _test(group, labels, value, block, alpha, source, f"{stem} at {dof} DOF and {evaluations} evaluations"),
            )
        )
    return _write_rankings(
        runs,
        out,
        name,
        variant,
        value,
        f"{dof}-DOF model, the algorithms per budget",
        tests,
        [f"{k['evaluations']} ev." for k, _ in tests],
        "algorithm",
        block,
        alpha,
        source,
    )


def table4(runs, frames, out, **options) -> Outputs:
    """Yeguas Table 4: the algorithms at 39 DOF, per variant and ranking."""
    return _each_variant(yeguas_rankings, runs, out, name="table4", dof=39, **options)


def table5(runs, frames, out, **options) -> Outputs:
    """Yeguas Table 5: the algorithms at 28 DOF, per variant and ranking."""
    return _each_variant(yeguas_rankings, runs, out, name="table5", dof=28, **options)


def strategy_variants(
    runs: pd.DataFrame,
    out: Path,
    *,
    name: str,
    hierarchical: bool,
    value: str,
    variant: dict,
    block=DEFAULT_BLOCK,
    alpha: float = 0.05,
    source: str = "runs",
) -> Outputs:
    """Yeguas Table 6 (hierarchical) or 7 (holistic) of the runs of one variant
    (:func:`variants`): each algorithm's DOF x budget variants ranked by the column ``value``
    (one of :data:`RANKINGS`)."""
    runs = checked(runs, ["optimizer", "strategy", "dof", "evaluations", value, *block], source)
    stem = table_stem(name, variant, value)
    runs = runs[is_hierarchical(runs) == hierarchical]
    kind = "hierarchical" if hierarchical else "holistic"
    if runs.empty:
        raise DataError(f"{source}: no {kind} runs for {stem}")
    tests = []
    for optimizer, strategy in by_optimizer(zip(runs.optimizer, runs.strategy)):
        group = runs[(runs.optimizer == optimizer) & (runs.strategy == strategy)]
        labels = [paper_label(optimizer, strategy, d, e) for d, e in zip(group.dof, group.evaluations)]
        tests.append(
            (
                {"algorithm": short_name(optimizer, strategy)},
                _test(
                    group,
                    labels,
                    value,
                    block,
                    alpha,
                    source,
                    f"{stem} for {short_name(optimizer, strategy)}",
                    "variant",
                ),
            )
        )
    return _write_rankings(
        runs,
        out,
        name,
        variant,
        value,
        f"{kind} approaches, each algorithm's DOF x evaluations variants",
        tests,
        [k["algorithm"] for k, _ in tests],
        "variant",
        block,
        alpha,
        source,
    )


def table6(runs, frames, out, **options) -> Outputs:
    """Yeguas Table 6: hierarchical algorithms across DOF and budgets, per variant and ranking."""
    return _each_variant(strategy_variants, runs, out, name="table6", hierarchical=True, **options)


def table7(runs, frames, out, **options) -> Outputs:
    """Yeguas Table 7: holistic algorithms across DOF and budgets, per variant and ranking."""
    return _each_variant(strategy_variants, runs, out, name="table7", hierarchical=False, **options)


def frame_errors(runs: pd.DataFrame, frames: pd.DataFrame | None, source: str) -> pd.DataFrame:
    """The frames joined with their run's columns. A frame of an unknown run, without a run_id,
    with a frame number that is not a whole number or an error that is not a number (or is
    infinite) is a DataError naming frames.csv; frames without ground truth (an empty error)
    are left out, with a warning saying how many."""
    if frames is None:
        raise DataError(f"{source}: no frames.csv beside the runs")
    frames_source = str(Path(source).with_name("frames.csv"))
    require_columns(frames, ["run_id", "frame", "marker_error_mm"], frames_source)
    no_empty_cells(frames, ["run_id"], frames_source)
    errors = finite_numbers(frames, "marker_error_mm", frames_source, missing_ok=True)
    frames = frames.assign(frame=whole_numbers(frames, "frame", frames_source), marker_error_mm=errors)
    unknown = sorted(set(frames["run_id"]) - set(runs["run_id"]))
    if unknown:
        raise DataError(f"{frames_source}: frames of {len(unknown)} run(s) not in runs.csv, e.g. {unknown[0]!r}")
    unscored = np.isnan(errors)
    if unscored.any():
        warnings.warn(
            f"{frames_source}: {int(unscored.sum())} of {len(frames)} frame(s), of "
            f"{frames.loc[unscored, 'run_id'].nunique()} run(s), have no marker error (no ground "
            "truth) and are left out of the figure",
            MmocapWarning,
            stacklevel=2,
        )
        frames = frames[~unscored]
    return frames.merge(runs, on="run_id", how="inner")


def _variants_of_frames(
    build: Callable[..., Outputs],
    name: str,
    runs: pd.DataFrame,
    frames: pd.DataFrame | None,
    out: Path,
    source: str,
    **options,
) -> Outputs:
    """``build(runs, data, path, variant, ...)`` for each variant (:func:`variants`), with its
    runs, their frames joined with the runs (:func:`frame_errors`, which checks every frame
    once) and the figure's path ``out/figures/<name>_<variant>.png``."""
    runs = checked(runs, ["run_id", "optimizer", "strategy", "dof", "evaluations", "sequence"], source)
    data = frame_errors(runs, frames, source)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    return [
        path
        for variant, group in variants(runs)
        for path in build(
            group,
            data[data.run_id.isin(group.run_id)],
            out / "figures" / f"{variant_stem(name, variant)}.png",
            variant,
            source=source,
            **options,
        )
    ]


def fig7(runs, frames, out, *, source: str = "runs", **_) -> Outputs:
    """Yeguas Fig. 7: box plots of the error of every frame, per sequence and algorithm-DOF,
    one figure per variant (``fig7_<realism>_<settings>.png``)."""
    return _variants_of_frames(_fig7, "fig7", runs, frames, out, source)


def _fig7(runs: pd.DataFrame, data: pd.DataFrame, path: Path, variant: dict, *, source: str) -> Outputs:
    pair = [f"{short_name(o, s)}({d})" for o, s, d in zip(data.optimizer, data.strategy, data.dof)]
    pairs = [
        f"{short_name(o, s)}({d})"
        for o, s in by_optimizer(zip(data.optimizer, data.strategy))
        for d in sorted(data.dof.unique(), reverse=True)
    ]
    budgets = [f"{e} evaluations" for e in sorted(data.evaluations.unique())]
    data = data.assign(
        pair=pd.Categorical(pair, pairs),
        budget=pd.Categorical([f"{e} evaluations" for e in data.evaluations], budgets),
        kind=np.where(is_hierarchical(data), "hierarchical", "holistic"),
    )
    figures.plot_grouped_boxplots(
        data,
        path,
        value="marker_error_mm",
        x="sequence",
        hue="pair",
        panel=["budget", "kind"],
        ylabel="marker error (mm)",
        title=f"Marker error of every frame of every run (Yeguas Fig. 7){variant_words(variant)}",
        note=provenance(describe_runs(runs, source)),
    )
    return [path]


def _prefer(values, wanted):
    values = sorted(values)
    return wanted if wanted in values else values[len(values) // 2]


def fig10(
    runs,
    frames,
    out,
    *,
    source: str = "runs",
    sequence: str | None = None,
    dof: int | None = None,
    evaluations: int | None = None,
    **_,
) -> Outputs:
    """Yeguas Fig. 10: error per frame of the holistic algorithms on one sequence, one figure
    per variant (``fig10_<realism>_<settings>.png``).

    Defaults as in the paper where the runs have them: S1_walking, 39 DOF, 1500 evaluations
    (else the first sequence, the middle DOF and budget). Several seeds: their mean, with
    a band from the lowest to the highest.
    """
    return _variants_of_frames(
        _fig10, "fig10", runs, frames, out, source, sequence=sequence, dof=dof, evaluations=evaluations
    )


def _fig10(
    runs: pd.DataFrame,
    data: pd.DataFrame,
    path: Path,
    variant: dict,
    *,
    source: str,
    sequence: str | None,
    dof: int | None,
    evaluations: int | None,
) -> Outputs:
    holistic = data[~is_hierarchical(data)]
    data = holistic if not holistic.empty else data
    sequence = sequence or _prefer(data.sequence.unique(), "S1_walking")
    dof = dof or _prefer(data.dof.unique(), 39)
    evaluations = evaluations or _prefer(data.evaluations.unique(), 1500)
    data = data[(data.sequence == sequence) & (data.dof == dof) & (data.evaluations == evaluations)]
    if data.empty:
        raise DataError(f"{source}: no frames of {sequence} at {dof} DOF, {evaluations} evaluations")
    data = data.assign(name=[short_name(o, s) for o, s in zip(data.optimizer, data.strategy)])
    order = [short_name(o, s) for o, s in by_optimizer(zip(data.optimizer, data.strategy))]
    per_frame = data.groupby(["frame", "name"])["marker_error_mm"]  # (frames, algorithms) each
    table = pd.concat(
        {
            "mean": per_frame.agg(overflow_free_mean).unstack(),
            "min": per_frame.min().unstack(),
            "max": per_frame.max().unstack(),
        },
        axis=1,
    )
    seeds = data.groupby("name")["run_id"].nunique()
    origin = describe_runs(data.drop_duplicates("run_id"), source)
    figures.plot_error_curves(
        table["mean"][order],
        path,
        note=provenance(origin),
        title=f"{sequence}, {dof} DOF, {evaluations} evaluations per frame"
        + (f", mean of {seeds.max()} runs (band: min-max)" if seeds.max() > 1 else "")
        + variant_words(variant),
        spread=(table["min"][order], table["max"][order]) if seeds.max() > 1 else None,
    )
    return [path]


def _configuration_label(vertices: int, evaluations: int) -> str:
    return f"{vertices} v, {evaluations} ev."


def cano_table3(runs, frames, out, *, block=DEFAULT_BLOCK, source: str = "runs", **_) -> Outputs:
    """Cano Table 3: error (mm) per sequence of each mesh level x budget, its average over the
    sequences and the configurations' Friedman ranks, one table per variant
    (``cano_table3_<realism>``)."""
    return [
        path
        for variant, group in variants(runs)
        for path in _cano_table3(group, out, variant, block=block, source=source)
    ]


def _cano_table3(runs: pd.DataFrame, out: Path, variant: dict, *, block, source: str) -> Outputs:
    stem = variant_stem("cano_table3", variant)
    runs = checked(runs, ["algorithm", "dof", "vertices", "evaluations", "sequence", ERROR, *block], source)
    setups = runs[["algorithm", "dof"]].drop_duplicates()
    if len(setups) > 1:
        held = ", ".join(f"{a}/{d}" for a, d in setups.itertuples(index=False))
        raise DataError(
            f"{source}: {stem} compares the mesh levels and budgets of one algorithm and DOF, the runs hold {held}"
        )
    configurations = (
        runs[["vertices", "evaluations"]]
        .drop_duplicates()
        .sort_values(["vertices", "evaluations"], ascending=[False, True])
    )
    columns = [_configuration_label(v, e) for v, e in configurations.itertuples(index=False)]
    runs = runs.assign(configuration=[_configuration_label(v, e) for v, e in zip(runs.vertices, runs.evaluations)])
    test = _test(runs, runs.configuration, ERROR, block, 0.05, source, stem, "configuration")
    per_sequence = runs.pivot_table(
        index="sequence", columns="configuration", values=ERROR, aggfunc=overflow_free_mean
    )[columns]
    ranks = test.comparisons.set_index("algorithm")["rank"]
    table = pd.concat(
        [
            per_sequence,
            per_sequence.agg(overflow_free_mean).to_frame("Avg. Error").T,
            ranks.reindex(columns).to_frame("Ranks").T,
        ]
    )
    table = table.rename_axis("Sequence").reset_index()
    algorithm, dof = setups.iloc[0]
    title = (
        f"Cano Table 3: mean marker error (mm) of {algorithm}, {dof} DOF, per mesh level "
        f"(vertices) x evaluations per frame; Ranks: Friedman over {test.n_blocks} blocks "
        f"({' x '.join(block)}), chi2_F = {test.statistic:.3f}, p = {format_p(test.p_value)}"
        f"{variant_words(variant)}"
    )
    return write_table(table, out / "tables" / stem, title=title, source=describe_runs(runs, source), floatfmt=".2f")


def fig4(runs, frames, out, *, source: str = "runs", **_) -> Outputs:
    """Cano Fig. 4: time per frame against error of each mesh level x budget x backend, the
    Pareto front linked; the configurations also as a table; one of each per variant
    (``fig4_<realism>``)."""
    return [path for variant, group in variants(runs) for path in _fig4(group, out, variant, source=source)]


def _fig4(runs: pd.DataFrame, out: Path, variant: dict, *, source: str) -> Outputs:
    stem = variant_stem("fig4", variant)
    table = summarise(runs, source=source)
    path = out / "figures" / f"{stem}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    origin = describe_runs(runs, source)
    figures.plot_pareto_front(
        table,
        path,
        note=provenance(origin),
        title=f"Time per frame against marker error (Cano Fig. 4){variant_words(variant)}",
    )
    title = (
        "Cano Fig. 4: mean time per frame (s) and marker error (mm) of each configuration; "
        f"pareto = not dominated on both{variant_words(variant)}"
    )
    return [path] + write_table(table, out / "tables" / stem, title=title, source=origin, floatfmt=".4g")


#: the largest ratio of the error from the automatic start to the error from the true start
#: that counts as a success (with keypoints; the silhouettes alone were held to 1.5)
AUTOSTART_GOAL = 1.2


def autostart(runs, frames, out, *, source: str = "runs", **_) -> Outputs:
    """The automatic start (``+experiment=autostart``): per sequence (a turned motion, column
    ``turn_deg``, counting as a sequence of its own), the mean marker error tracked from the
    sequence's first pose (start ``given``) and from nothing (start ``search`` or
    ``keypoints``: first pose and body size found), their ratio against
    :data:`AUTOSTART_GOAL`, and what the start cost in seconds."""
    runs = checked(runs, ["sequence", "start", ERROR], source)
    if "turn_deg" in runs and (runs.turn_deg != 0).any():  # the same motion turned: a sequence of its own
        runs = runs.assign(
            sequence=runs.sequence + np.where(runs.turn_deg != 0, [f" turned {t:g}" for t in runs.turn_deg], "")
        )
    searched = checked(runs[runs.start != "given"], ["start_seconds"], source)  # the search, or from keypoints
    by_start = {"given": runs[runs.start == "given"].groupby("sequence"), "search": searched.groupby("sequence")}
    if any(len(group) == 0 for group in by_start.values()):
        raise DataError(
            f"{source}: autostart compares runs with start given and start search; "
            f"the runs hold {', '.join(sorted(runs.start.unique()))}"
        )
    table = pd.DataFrame(
        {
            "given (mm)": by_start["given"][ERROR].agg(overflow_free_mean),
            "automatic (mm)": by_start["search"][ERROR].agg(overflow_free_mean),
            "start (s)": by_start["search"]["start_seconds"].agg(overflow_free_mean),
        }
    ).dropna()
    if table.empty:
        raise DataError(f"{source}: no sequence has runs with both start given and start search")
    table.insert(2, "ratio", table["automatic (mm)"] / table["given (mm)"])
    table["goal met"] = np.where(table["ratio"] <= AUTOSTART_GOAL, "yes", "no")
    table = table.rename_axis("Sequence").reset_index()
    title = (
        f"Automatic start: mean marker error (mm) from the sequence's first pose (given) and from nothing "
        f"(automatic: the first pose and the body's size found); goal: ratio <= {AUTOSTART_GOAL} (met on "
        f"{int((table['goal met'] == 'yes').sum())} of {len(table)} sequences)"
    )
    return write_table(
        table, out / "tables" / "autostart", title=title, source=describe_runs(runs, source), floatfmt=".2f"
    )


#: the mean marker error (mm) the hybrid fitness must reach per realism level on the
#: realistic benchmark (issue: 18 mm against 24.7 silhouette-only, 30 mm against 42.1)
KEYPOINT_GOALS_MM = {"realistic": 18.0, "hard": 30.0}


def keypoint_weight(runs, frames, out, *, source: str = "runs", **_) -> Outputs:
    """The keypoint term's weight (``+experiment=keypoint_weight``): per realism level and
    weight, the mean marker error over the seeds (and its standard deviation), the ratio
    to silhouettes only (weight 0) of the same level, and whether the level's goal
    (:data:`KEYPOINT_GOALS_MM`) is met."""
    runs = checked(runs, ["realism", "keypoint_weight", "seed", ERROR], source)
    groups = runs.groupby(["realism", "keypoint_weight"])[ERROR]
    table = pd.DataFrame({"mean (mm)": groups.agg(overflow_free_mean), "sd (mm)": groups.std(), "seeds": groups.size()})
    table = table.reset_index()
    silhouettes = table[table.keypoint_weight == 0].set_index("realism")["mean (mm)"]
    if silhouettes.empty:
        raise DataError(f"{source}: keypoint_weight needs runs at weight 0 (silhouettes only) to compare with")
    table["vs silhouettes"] = table["mean (mm)"] / table.realism.map(silhouettes)
    goals = table.realism.map(KEYPOINT_GOALS_MM)
    table["goal (mm)"] = goals
    table["goal met"] = np.where(goals.isna(), "", np.where(table["mean (mm)"] <= goals, "yes", "no"))
    table = table.rename(columns={"realism": "Realism", "keypoint_weight": "weight"})
    best = table[table.weight > 0].sort_values("mean (mm)").groupby("Realism").head(1)
    chosen = ", ".join(f"{r.Realism}: weight {r.weight:g} ({r['mean (mm)']:.1f} mm)" for _, r in best.iterrows())
    title = f"Keypoint term weight: mean marker error (mm) over the seeds; weight 0 = silhouettes only; best {chosen}"
    return write_table(
        table, out / "tables" / "keypoint_weight", title=title, source=describe_runs(runs, source), floatfmt=".2f"
    )


MAKERS: dict[str, Callable[..., Outputs]] = {
    "table4": table4,
    "table5": table5,
    "table6": table6,
    "table7": table7,
    "fig7": fig7,
    "fig10": fig10,
    "cano_table3": cano_table3,
    "fig4": fig4,
    "autostart": autostart,
    "keypoint_weight": keypoint_weight,
}


def load_sweep(folder: Path) -> tuple[pd.DataFrame, pd.DataFrame | None]:
    """``runs.csv`` of ``folder`` (required) and its ``frames.csv`` (None when absent)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError(f"{folder}: no such folder")
    runs = read_table(folder / "runs.csv")
    if runs.empty:
        raise DataError(f"{folder / 'runs.csv'}: no runs")
    frames_path = folder / "frames.csv"
    return runs, read_table(frames_path) if frames_path.is_file() else None


def make(names: list[str], folder: Path, out: Path, **options) -> tuple[Outputs, dict[str, str]]:
    """Make each named table or figure; returns the files written and, for ``all``, the
    reasons of the ones skipped (a single name's error is raised)."""
    runs, frames = load_sweep(folder)
    source = str(Path(folder) / "runs.csv")
    written, skipped = [], {}
    for name in names:
        try:
            written += MAKERS[name](runs, frames, Path(out), source=source, **options)
        except DataError as err:
            if len(names) == 1:
                raise
            skipped[name] = str(err)
    if not written:
        reasons = "; ".join(f"{n}: {e}" for n, e in skipped.items())
        raise DataError(f"{source}: nothing could be made: {reasons}")
    return written, skipped


def main(argv: list[str], prog: str) -> None:
    """``mmocap paper NAME FOLDER``: make a paper table or figure (or ``all``) from a sweep's
    runs.csv."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    parser.add_argument("name", choices=[*MAKERS, "all"])
    parser.add_argument("folder", type=Path, help="folder holding runs.csv (and frames.csv)")
    parser.add_argument(
        "--out", type=Path, default=Path("outputs"), help="writes OUT/tables/ and OUT/figures/ (default: %(default)s)"
    )
    parser.add_argument(
        "--block", default=",".join(DEFAULT_BLOCK), help="columns naming a Friedman block (default: %(default)s)"
    )
    parser.add_argument("--alpha", type=float, default=0.05, help="Holm's significance level")
    parser.add_argument(
        "--page", type=Path, help="also put the tables made on this results page (e.g. docs/results/table4.md)"
    )
    parser.add_argument("--target", help="the make target the page's stamp names (default: NAME)")
    args = parser.parse_args(argv)
    names = list(MAKERS) if args.name == "all" else [args.name]
    block = tuple(c.strip() for c in args.block.split(",") if c.strip())
    alpha = check_number("--alpha", args.alpha, 0, 1, low_open=True, high_open=True)
    written, skipped = make(names, args.folder, args.out, block=block, alpha=alpha)
    for name, reason in skipped.items():
        print(f"skipped {name}: {reason}")
    print("written: " + ", ".join(map(str, written)))
    if args.page is not None:
        tables = [Path(path) for path in written if Path(path).suffix == ".md"]
        sections = {path.stem: page_section(Path(path).read_text()) for path in tables}
        update_page(args.page, args.target or args.name, None, sections, order=[path.stem for path in tables])
        print(f"written: {args.page}")
