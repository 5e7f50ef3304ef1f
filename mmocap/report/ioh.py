"""Per-frame convergence traces of tracking runs, in the IOHprofiler format for IOHanalyzer.

A tracking run writes ``traces.csv`` into its folder (:mod:`mmocap.writers.traces`): for
every frame, the best fitness so far against the evaluations spent on the frame.

``mmocap ioh FOLDER [--out DIR]`` reads every finished run below FOLDER (a run folder or a
sweep folder: each folder holding ``summary.json`` and ``traces.csv``) and writes into DIR
(default ``FOLDER/ioh``) the files the ``ioh`` package's ``Analyzer`` logger (version 0.4.2)
writes, which IOHanalyzer loads (upload DIR as a zip file, or ``DataSetList("DIR")`` in R)::

    DIR/<algorithm>/IOHprofiler_f<id>_<function>.json
    DIR/<algorithm>/data_f<id>_<function>/IOHprofiler_f<id>_DIM<dimension>.dat

The mapping of a sweep onto IOHprofiler's terms:

- algorithm: ``<optimizer>-<strategy>`` (``cmaes-holistic``), followed by ``-<preset>`` when
  the run named an optimiser settings preset (``settings=paper``);
- function: the sequence, ``<subject>_<action>`` (``S1_walking``; a sequence without an
  action: the name of its folder), followed by ``_<realism>`` for synthetic data rendered at
  a realism level other than ``exact`` (``S1_walking_realistic``); ids 1, 2, ... in the
  order of the names, the same in every algorithm's folder;
- dimension: the degrees of freedom searched (``dof``: 39 or 28);
- run: one frame of one run, its instance the frame number + 1; the runs of a function and
  dimension in the order of the run folders' paths, then of the frames. A frame's budget
  (``evaluations_per_frame``) is its run's length; the algorithm's ``info`` lists them.

A ``.dat`` file holds, for each run, a header line ``evaluations raw_y``, then one line
``<evaluations> <best fitness so far>`` per row of the frame's trace. The JSON file holds
``version``, ``suite`` (``mmocap``), ``function_id``, ``function_name``, ``maximization``
(false), ``algorithm`` (``name``, ``info``), ``attributes`` and, per dimension, a scenario
with the ``.dat`` file's ``path`` and, per run, its ``instance``, ``evals`` (evaluations
spent) and ``best`` (``evals``: the evaluation that found the best fitness, ``y``: that
fitness); ioh's ``best.x`` is left out (the poses are in ``frames.csv``), and the fitness is
written in full rather than to ioh's 10 decimals. An export first removes the IOHprofiler
files an earlier export left in DIR.
"""

from __future__ import annotations

import argparse
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mmocap.analysis.results import variant_names
from mmocap.errors import DataError
from mmocap.io import write_json_atomic, write_text_atomic, writing
from mmocap.run_folder import SUMMARY, TRACES, read_summary, summary_paths
from mmocap.writers.traces import read_traces

#: the ioh release whose Analyzer files these are (IOHanalyzer reads those of 0.3.3 and later)
IOH_VERSION = "0.4.2"
SUITE = "mmocap"
DAT_HEADER = "evaluations raw_y"


@dataclass
class Run:
    """A finished run's traces (frame -> (k, 2) evaluations, best fitness) and its place in
    the IOHprofiler layout (module docstring)."""

    folder: Path
    algorithm: str
    function: str
    dimension: int
    evaluations_per_frame: int
    traces: dict[int, np.ndarray]


def load_run(folder: str | Path) -> Run:
    """The run in ``folder`` (its ``summary.json``, read by :func:`mmocap.run_folder.read_summary`,
    and ``traces.csv``); a DataError naming the file and entry that is missing or wrong, or the
    frames missing from the traces."""
    folder = Path(folder)
    summary = read_summary(folder)
    preset, realism = variant_names(summary.config)
    algorithm = "-".join([summary.optimizer, summary.strategy, *([str(preset)] if preset else [])])
    action = summary.action
    function = f"{summary.subject}_{action}" if action is not None else Path(summary.sequence).name
    if realism not in (None, "exact"):
        function += f"_{realism}"
    traces = read_traces(folder / TRACES)
    missing = sorted(set(range(summary.frames)) - set(traces))
    extra = sorted(set(traces) - set(range(summary.frames)))
    if missing or extra:
        raise DataError(
            f"{folder / TRACES} does not hold the {summary.frames} frames of {folder / SUMMARY}: "
            f"missing {missing[:5] or 'none'}, unknown {extra[:5] or 'none'}"
        )
    return Run(folder, algorithm, function, summary.dof, summary.evaluations_per_frame, dict(sorted(traces.items())))


def find_runs(folder: str | Path) -> list[Run]:
    """Every finished run below ``folder`` (each folder holding a ``summary.json``), in the
    order of their paths; a DataError if there is none."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError(f"no such folder: {folder}")
    paths = summary_paths(folder)
    if not paths:
        raise DataError(f"no finished run (a folder holding {SUMMARY}) below {folder}")
    return [load_run(path.parent) for path in paths]


def file_name(name: str) -> str:
    """``name`` with every run of characters other than letters, digits, ``_``, ``.`` and ``-``
    replaced by ``-``, for a file or folder name."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", name)


def dat_text(traces: list[np.ndarray]) -> str:
    """A ``.dat`` file of ``traces`` ((k, 2) evaluations, best fitness each), one run each."""
    lines = []
    for trace in traces:
        lines.append(DAT_HEADER)
        lines += [f"{int(evaluations)} {float(fitness)!r}" for evaluations, fitness in trace]
    return "\n".join(lines) + "\n"


def run_entry(frame: int, trace: np.ndarray) -> dict:
    """A run of the JSON file's scenario for a frame's ``trace`` ((k, 2) evaluations, best
    fitness): instance frame + 1, the evaluations spent, the first evaluation at the best."""
    best = int(np.argmin(trace[:, 1]))
    return {
        "instance": frame + 1,
        "evals": int(trace[-1, 0]),
        "best": {"evals": int(trace[best, 0]), "y": float(trace[best, 1])},
    }


def clear_export(out: Path) -> None:
    """Remove the IOHprofiler files an earlier export wrote into ``out``, and the folders they
    leave empty; other files stay."""
    with writing(out):
        files = [*out.glob("*/data_f*/IOHprofiler_f*_DIM*.dat"), *out.glob("*/IOHprofiler_f*.json")]
        for path in files:
            path.unlink()
        folders = {path.parent for path in files}
        for folder in sorted(folders | {f.parent for f in folders if f.parent != out}, key=lambda f: -len(f.parts)):
            if not any(folder.iterdir()):
                folder.rmdir()


def write_ioh(runs: list[Run], out: str | Path) -> list[Path]:
    """Write the traces of ``runs`` into ``out`` in the IOHprofiler layout (module docstring),
    after removing an earlier export's files there; returns the JSON files written."""
    out = Path(out)
    clear_export(out)
    function_ids = {name: k for k, name in enumerate(sorted({run.function for run in runs}), start=1)}
    groups: dict[tuple[str, str], list[Run]] = {}
    for run in runs:
        groups.setdefault((run.algorithm, run.function), []).append(run)
    written = []
    for (algorithm, function), group in sorted(groups.items()):
        fid, name = function_ids[function], file_name(function)
        folder = out / file_name(algorithm)
        scenarios = []
        for dimension in sorted({run.dimension for run in group}):
            frames = [
                (frame, trace) for run in group if run.dimension == dimension for frame, trace in run.traces.items()
            ]
            path = f"data_f{fid}_{name}/IOHprofiler_f{fid}_DIM{dimension}.dat"
            write_text_atomic(folder / path, dat_text([trace for _, trace in frames]))
            scenarios.append(
                {"dimension": dimension, "path": path, "runs": [run_entry(frame, trace) for frame, trace in frames]}
            )
        budgets = ", ".join(str(b) for b in sorted({run.evaluations_per_frame for run in group}))
        meta = {
            "version": IOH_VERSION,
            "suite": SUITE,
            "function_id": fid,
            "function_name": function,
            "maximization": False,
            "algorithm": {"name": algorithm, "info": f"mmocap tracking, {budgets} evaluations per frame"},
            "attributes": DAT_HEADER.split(),
            "scenarios": scenarios,
        }
        written.append(write_json_atomic(folder / f"IOHprofiler_f{fid}_{name}.json", meta))
    return written


def main(argv: list[str], prog: str) -> None:
    """``mmocap ioh FOLDER [--out DIR]``: the runs' convergence traces for IOHanalyzer."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="a run folder, or a sweep folder holding run folders")
    parser.add_argument("--out", type=Path, help="the folder to write into (default FOLDER/ioh)")
    args = parser.parse_args(argv)
    out = args.folder / "ioh" if args.out is None else args.out
    runs = find_runs(args.folder)
    written = write_ioh(runs, out)
    print(
        f"IOHprofiler data of {len(runs)} run(s), {sum(len(run.traces) for run in runs)} frame(s), "
        f"{len({run.algorithm for run in runs})} algorithm(s), {len(written)} meta-data file(s) in {out}"
    )
