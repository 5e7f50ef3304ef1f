"""A run's per-frame convergence traces, ``traces.csv`` (:data:`mmocap.run_folder.TRACES`).

For every frame: the best fitness so far (Yeguas Eq. 5: in [0, 1], 0 = the model covers the
foreground exactly, minimised) against the evaluations spent on the frame, counted from 1 (its
start pose) in the order the candidates were evaluated, a recovery's included. Columns
``frame, evaluations, best_fitness``: one row at every evaluation that improved on all before
it, and one at the frame's last evaluation, which is its ``evaluations`` and ``fitness`` in
``frames.csv``. ``mmocap ioh`` (:mod:`mmocap.report.ioh`) turns them into IOHprofiler files.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mmocap.errors import DataError
from mmocap.io import check_whole_lines, write_text_atomic

TRACE_COLUMNS = ("frame", "evaluations", "best_fitness")


def write_traces(path: str | Path, results) -> Path:
    """Write the ``trace`` ((k, 2): evaluations, best fitness) of each of ``results``
    (:class:`mmocap.stages.tracking.FrameResult`) to ``path`` atomically; returns it."""
    lines = [",".join(TRACE_COLUMNS)]
    for result in results:
        lines += [f"{result.frame},{int(evaluations)},{float(fitness)!r}" for evaluations, fitness in result.trace]
    return write_text_atomic(path, "\n".join(lines) + "\n")


def read_traces(path: str | Path) -> dict[int, np.ndarray]:
    """The traces of ``traces.csv``: frame -> (k, 2) float64 rows (evaluations, best fitness so
    far). A DataError naming the file and line if it is missing or is not a trace table: the
    columns of :data:`TRACE_COLUMNS`, integer frames and evaluations, finite fitness, each
    frame's rows together with the evaluations rising from 1 and the fitness never rising; or
    its last line when that has no line end (the file may be cut short:
    :func:`mmocap.io.check_whole_lines`)."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path} is missing: that run was tracked before traces were recorded; track it again")
    data = path.read_bytes()
    check_whole_lines(data, str(path))
    try:
        lines = data.decode("utf-8").splitlines()
    except UnicodeDecodeError:
        raise DataError(f"{path} is not a text file") from None
    if not lines or lines[0].strip() != ",".join(TRACE_COLUMNS):
        raise DataError(f"{path}: the first line must be the header {','.join(TRACE_COLUMNS)}")
    rows: dict[int, list[tuple[int, float]]] = {}
    frame = None
    for number, line in enumerate(lines[1:], start=2):
        fields = line.split(",")
        try:
            if len(fields) != 3:
                raise ValueError
            row_frame, evaluations, fitness = int(fields[0]), int(fields[1]), float(fields[2])
            if not math.isfinite(fitness):
                raise ValueError
        except ValueError:
            raise DataError(
                f"{path} line {number}: {line!r:.60} is not 'frame,evaluations,best_fitness' "
                "(integers, then a finite number)"
            ) from None
        if row_frame != frame:
            if row_frame in rows:
                raise DataError(f"{path} line {number}: the rows of frame {row_frame} are not together")
            if evaluations != 1:
                raise DataError(
                    f"{path} line {number}: frame {row_frame}'s trace starts at evaluation {evaluations}, not 1"
                )
            frame, rows[row_frame] = row_frame, []
        elif evaluations <= rows[frame][-1][0] or fitness > rows[frame][-1][1]:
            raise DataError(
                f"{path} line {number}: frame {frame}'s ({evaluations}, {fitness}) follows "
                f"{rows[frame][-1]}: the evaluations must rise, the best fitness must not"
            )
        rows[frame].append((evaluations, fitness))
    return {frame: np.array(trace, dtype=np.float64) for frame, trace in rows.items()}
