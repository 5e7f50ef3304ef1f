"""Multi-fidelity against exact search (``mmocap bench fidelity``): the demo sequence (S1
walking, 640x480) on ``realistic`` data at one of :data:`WORKLOADS` (the demo's 4 cameras,
or Cano's 7 cameras and 27393 vertices), tracked by the real pipeline with
holistic CMA-ES, exactly at each of some evaluations per frame and with each schedule of
cheaper fitness levels before a short exact search (:mod:`mmocap.stages.fidelity`; carried
on, or restarted per level when a level names a popsize), one run at a time, each with
every search seed given (a single seed's error is too noisy a figure): mean marker error
and search time per frame averaged over the seeds side by side, the error's spread over
the seeds, their ratios to the exact run at :data:`FIDELITY_REFERENCE` evaluations, and
the Pareto front of both modes.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from mmocap.analysis.pareto import non_dominated
from mmocap.config import compose
from mmocap.errors import ConfigError
from mmocap.optimizers.cmaes import strategy_parameters
from mmocap.pipeline import run
from mmocap.stages.fidelity import check_levels
from mmocap.stages.tracking import MAX_EVALUATIONS, START_EVALUATIONS
from mmocap.validate import check_number

#: the multi-fidelity runs of ``mmocap bench fidelity`` unless ``--schedule`` is given
DEFAULT_SCHEDULES = ["0.25:3000:1000+350", "0.5:3000:1200+500:28", "0.5:3000:1400+400:28", "0.5:3000:1400+500:28"]
#: the exact run the multi-fidelity runs are compared with: CMA-ES at this many evaluations
FIDELITY_REFERENCE = 1500
#: the run every fidelity configuration shares (the demo sequence on realistic data, as the
#: papers' tables track, with their fitness, the silhouettes alone, and without the recovery
#: searches, whose extra evaluations vary)
FIDELITY_RUN = [
    "+experiment=demo",
    "realism=realistic",
    "keypoints.source=none",
    "recovery.enabled=false",
    "overlays=0",
    "progress=false",
    "foreground_cache=null",
]


@dataclass(frozen=True)
class Workload:
    """Cameras and vertices a fidelity benchmark tracks with: the table's section name, its
    description and the config overrides (after :data:`FIDELITY_RUN`) that set it."""

    table: str
    description: str
    overrides: tuple[str, ...]


#: the workloads of ``mmocap bench fidelity`` (the demo's) and ``fidelity-cano`` (Cano's Table
#: 1: 7 cameras, 27393 vertices), by subcommand
WORKLOADS = {
    "fidelity": Workload("fidelity", "4 cameras, 640x480", ()),
    "fidelity-cano": Workload(
        "fidelity_cano",
        "Cano's workload: 7 cameras, 640x480, 27393 vertices",
        ("dataset.cameras=[C1,C2,C3,BW1,BW2,BW3,BW4]", "body.vertices=27393"),
    ),
}


@dataclass(frozen=True)
class Search:
    """One search of the fidelity benchmark: its label (the text it was given), the cheaper
    levels (``fidelity.levels``, [] for an exact search), the exact evaluations per frame and
    CMA-ES's population size (None: the default, Table 2's)."""

    label: str
    levels: list
    exact: int
    popsize: int | None = None

    @property
    def carry(self) -> bool:
        """Carried on unless a level names its own optimiser settings (then restarted)."""
        return not any("optimizer" in level for level in self.levels)

    @property
    def mode(self) -> str:
        """``"exact"``, or ``"multi-fidelity (carried)"`` / ``"(restarted)"`` (see :attr:`carry`)."""
        return "exact" if not self.levels else f"multi-fidelity ({'carried' if self.carry else 'restarted'})"

    def overrides(self, frames: int, seed: int) -> list[str]:
        """The config overrides of one run of this search (after :data:`FIDELITY_RUN`)."""
        popsize = [] if self.popsize is None else [f"optimizer.popsize={self.popsize}"]
        return [
            f"seed={seed}",
            f"tracking.frames={frames}",
            f"tracking.evaluations={self.exact}",
            f"fidelity.levels={self.levels}".replace("'", ""),
            f"fidelity.carry={self.carry}",
            *popsize,
        ]


def exact_part(text: str, option: str) -> tuple[int, int | None]:
    """'EVALUATIONS[:POPSIZE]' -> (evaluations, popsize or None), checked; a ConfigError
    naming ``option`` otherwise."""
    evaluations_text, _, popsize_text = text.partition(":")
    try:
        evaluations, popsize = int(evaluations_text), int(popsize_text) if popsize_text else None
    except ValueError:
        raise ConfigError(f"{option} must be EVALUATIONS[:POPSIZE], e.g. 1500 or 1500:28, got {text!r}") from None
    check_number(option, evaluations, START_EVALUATIONS + 1, MAX_EVALUATIONS, integer=True)
    if popsize is not None:
        check_number(f"{option}'s popsize", popsize, 2, 10_000, integer=True)
    return evaluations, popsize


def parse_exact(text: str) -> list[Search]:
    """``--exact`` 'EVALUATIONS[:POPSIZE][,...]' (e.g. '1000,1500,1500:28') -> exact searches."""
    items = [item.strip() for item in text.split(",") if item.strip()]
    if not items:
        raise ConfigError(f"--exact must be EVALUATIONS[:POPSIZE][,...], e.g. 1000,1500:28, got {text!r}")
    return [Search(item, [], *exact_part(item, "--exact")) for item in items]


def parse_schedule(text: str) -> Search:
    """``--schedule`` 'SCALE:VERTICES:EVALUATIONS[:POPSIZE][,...]+EXACT[:POPSIZE]' (e.g.
    '0.25:3000:1200:28+300' or '0.25:1000:1400+400:28') -> its search: the levels, carried on
    with the whole search's population size after EXACT, or restarted when a level names its
    own; a ConfigError naming it otherwise."""
    levels_text, _, exact = text.partition("+")
    syntax = (
        f"--schedule must be SCALE:VERTICES:EVALUATIONS[:POPSIZE][,...]+EXACT[:POPSIZE], e.g. "
        f"0.25:3000:1200:28+300 or 0.25:1000:1400+400:28, got {text!r}"
    )
    try:
        levels = []
        for level in levels_text.split(","):
            scale, vertices, evaluations, *popsize = level.split(":")
            if len(popsize) > 1:
                raise ValueError(level)
            levels.append(
                {
                    "scale": float(scale),
                    "vertices": int(vertices),
                    "evaluations": int(evaluations),
                    **({"optimizer": {"popsize": int(popsize[0])}} if popsize else {}),
                }
            )
    except ValueError:
        raise ConfigError(syntax) from None
    check_levels(levels)
    search = Search(text, levels, *exact_part(exact, "--schedule's exact evaluations"))
    if search.popsize is not None and not search.carry:
        raise ConfigError(
            f"--schedule {text!r} names a popsize per level (restarted) and for the whole search "
            "(carried): give one or the other"
        )
    return search


def fidelity_table(
    searches: list[Search], frames: int, seeds: list[int], out: Path, workload: Workload = WORKLOADS["fidelity"]
) -> pd.DataFrame:
    """Track the demo sequence (:data:`FIDELITY_RUN`, ``frames`` frames, at ``workload``) with each search
    (exact or multi-fidelity), once per search seed of ``seeds`` (the data stay the same),
    one run after the other in a fresh folder; one row per search: mode, label, evaluations
    (cheap, exact), population size, the mean marker error (mm) and search time per frame
    (ms, the foreground apart), both averaged over the seeds, the spread of the error over
    the seeds (sample standard deviation, mm; 0 for one seed), the ratios to the exact run at
    :data:`FIDELITY_REFERENCE` evaluations and the default population size (when run) and
    ``pareto`` (not dominated on time and mean error)."""
    rows = []
    for search in searches:
        errors, times = [], []
        for seed in seeds:
            cfg = compose([*FIDELITY_RUN, *workload.overrides, *search.overrides(frames, seed)])
            with tempfile.TemporaryDirectory(dir=out) as folder:
                summary = run(cfg, Path(folder))
            errors.append(summary["mean_marker_error_mm"])
            times.append(summary["seconds_per_frame"] * 1e3)
            print(
                f"fidelity: {search.mode} {search.label}, seed {seed}: {errors[-1]:.1f} mm, "
                f"{times[-1]:.0f} ms per frame",
                flush=True,
            )
        rows.append(
            {
                "mode": search.mode,
                "evaluations": search.label,
                "cheap_evaluations": sum(level["evaluations"] for level in search.levels),
                "exact_evaluations": search.exact,
                "popsize": search.popsize or strategy_parameters(summary["dof"]).lam,
                "vertices": summary["vertices"],
                "seeds": len(seeds),
                "mean_marker_error_mm": float(np.mean(errors)),
                "error_sd_mm": float(np.std(errors, ddof=1)) if len(errors) > 1 else 0.0,
                "ms_per_frame": float(np.mean(times)),
            }
        )
    df = pd.DataFrame(rows)
    reference = [
        k
        for k, search in enumerate(searches)
        if not search.levels and search.exact == FIDELITY_REFERENCE and search.popsize is None
    ]
    if reference:
        df["error_ratio"] = df.mean_marker_error_mm / df.mean_marker_error_mm.iloc[reference[0]]
        df["time_ratio"] = df.ms_per_frame / df.ms_per_frame.iloc[reference[0]]
    df["pareto"] = non_dominated(df[["ms_per_frame", "mean_marker_error_mm"]].to_numpy())
    return df
