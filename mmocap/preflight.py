"""Checks of a composed tracking config before any data is read: for one run at its start,
and for a sweep, every job's config before the first job starts.

Each value is checked once, through :mod:`mmocap.validate`, and a bad one is a
:class:`~mmocap.errors.ConfigError` naming its key. Components check their own arguments:
those that are cheap to build (optimiser, strategy, coverage, dataset) are built; the body
model is checked without loading its mesh (:func:`mmocap.body.model.check_body`); the
evaluator's name was checked against the registry by Hydra's composition or the sweep's check,
and its arguments when it is built, still before any data is read.
"""

from __future__ import annotations

from types import SimpleNamespace

from hydra.utils import instantiate
from omegaconf import DictConfig

from mmocap.body.model import check_body
from mmocap.body.skeleton import dof_mask
from mmocap.data.sequence import check_missing_markers
from mmocap.errors import ConfigError
from mmocap.stages.tracking import check_budget
from mmocap.validate import check_flag, check_number
from mmocap.writers.export import check_formats

#: what a run does when another run holds its run folder (``run_dir_busy``)
RUN_DIR_BUSY = ("refuse", "wait")


def check_run_dir_busy(value) -> str:
    """``value`` if it is one of :data:`RUN_DIR_BUSY`, else a ConfigError naming ``run_dir_busy``."""
    if value not in RUN_DIR_BUSY:
        raise ConfigError(f"run_dir_busy must be one of {', '.join(RUN_DIR_BUSY)}, got {value!r}")
    return value


def check_config(cfg: DictConfig) -> None:
    """ConfigError naming the key of the first bad value of the tracking config ``cfg``."""
    check_number("seed", cfg.seed, 0, 2**32 - 1, integer=True)
    check_flag("progress", cfg.progress)
    check_flag("video", cfg.video)
    check_number("overlays", cfg.overlays, 0, 10_000, integer=True)
    check_formats(cfg.export, "export")
    instantiate(cfg.export_options)
    evaluations = check_budget(cfg.tracking.evaluations)
    if cfg.tracking.frames is not None:
        check_number("tracking.frames", cfg.tracking.frames, 1, integer=True)
    check_run_dir_busy(cfg.run_dir_busy)
    check_missing_markers(cfg.evaluation.missing_markers)
    check_body(
        cfg.body.subject,
        cfg.body.dof,
        cfg.body.vertices,
        cfg.body.seed,
        cfg.body.get("height_mm"),
        cfg.body.get("girth"),
    )
    optimizer = instantiate(cfg.optimizer)
    strategy = instantiate(cfg.strategy)
    dof = int(cfg.body.dof)
    strategy.check(SimpleNamespace(dof=dof, mask=dof_mask(dof)), optimizer, evaluations)  # needs the DOF only
    instantiate(cfg.coverage)
    instantiate(cfg.start)
    instantiate(cfg.recovery)
    instantiate(cfg.plausibility)
    instantiate(cfg.dataset)
