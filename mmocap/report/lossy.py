"""Lossy video: tracking from nothing on compressed recordings against their lossless twins.

``make lossy`` runs three steps over the synthetic sequences of a scale (``conf/experiment/lossy.yaml``):

1. ``mmocap lossy prepare [overrides]`` renders each sequence (``dataset.subject`` x
   ``lossy.action`` of the scale) if needed and writes it as a recording once per
   ``lossy.crfs`` value (:func:`mmocap.data.recording.reader.write_recording`: the tracked
   cameras, the world turned by ``lossy.yaw_deg``, H.264 at that ``crf``, the empty-scene
   plate at the same ``crf``) into ``lossy.recordings/<subject>_<action>_crf<crf>/``; a
   recording already written from the same sequence, crf and yaw is kept;
2. the sweep ``mmocap -m +experiment=lossy scale@lossy=SCALE`` tracks every recording from
   nothing (``start.mode=search``: no first pose, the body's height and girth fitted);
3. ``mmocap lossy table FOLDER [--page PAGE --target T]`` reads the sweep's run records and
   writes ``outputs/tables/lossy.{csv,md,tex}``: per sequence, the mean marker error of the
   lossless run and of each compressed one, their ratio against :data:`LOSSY_GOAL`, and the
   mean foreground fraction of the tracked frames of each (from the runs' foreground
   cache, computed again where it is missing).

``overrides`` are Hydra overrides composed with ``+experiment=lossy`` (``scale@lossy=smoke``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd
from hydra.errors import ConfigCompositionException
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf

from mmocap import config
from mmocap.analysis.results import ResultsStore
from mmocap.analysis.tables import write_table
from mmocap.data.recording.reader import write_recording
from mmocap.data.sequence import Sequence
from mmocap.errors import ConfigError, DataError
from mmocap.io import read_json_object, write_json_atomic
from mmocap.pipeline import open_foreground
from mmocap.report.results_page import page_section, update_page
from mmocap.stages.foreground import Foreground

#: the largest ratio of a compressed recording's error to its lossless one's that counts as
#: a success (the issue's goal)
LOSSY_GOAL = 1.5
EXPERIMENT = "+experiment=lossy"


def compose(overrides: list[str]) -> DictConfig:
    """The lossy experiment's config with ``overrides``; a ConfigError naming them otherwise."""
    try:
        return config.compose([EXPERIMENT, *overrides])
    except ConfigCompositionException as exc:
        raise ConfigError(f"{' '.join(overrides) or EXPERIMENT}: {str(exc).splitlines()[0]}") from None


def _values(text) -> list[str]:
    """A sweep value such as ``"S1,S2"`` (or a single value) -> its items."""
    return [item.strip() for item in str(text).split(",") if item.strip()]


def recording_name(subject: str, action: str, crf: int) -> str:
    """The folder of one recording under ``lossy.recordings``."""
    return f"{subject}_{action}_crf{crf}"


def prepare(overrides: list[str], progress: bool = False, out=print) -> list[Path]:
    """Render the scale's sequences and write their recordings (module docstring, step 1);
    returns the recording folders."""
    cfg = compose(overrides)
    lossy = cfg.lossy
    crfs = [int(c) for c in _values(lossy.crfs)]
    # the synthetic sequences as the scale renders them for the other experiments
    data_overrides = [f"dataset.{key}={value}" for key, value in lossy.dataset.items()]
    written = []
    for subject in _values(lossy.scale.subjects):
        for action in _values(lossy.scale.actions):
            synthetic = config.compose(
                [*data_overrides, f"dataset.subject={subject}", f"dataset.action={action}", "progress=false"]
            )
            sequence = instantiate(synthetic.dataset).open(progress=progress)
            sequence = Sequence.open(sequence.root, list(synthetic.dataset.cameras))
            for crf in crfs:
                folder = Path(lossy.recordings) / recording_name(subject, action, crf)
                fresh = ensure_recording(sequence, folder, crf, float(lossy.yaw_deg), progress)
                out(f"recording {folder}: {'written' if fresh else 'up to date'} (crf {crf})")
                written.append(folder)
    return written


def ensure_recording(sequence: Sequence, folder: Path, crf: int, yaw_deg: float = 0.0, progress: bool = False) -> bool:
    """Write ``sequence`` (its cameras) as the recording ``folder`` at ``crf`` with its world
    turned by ``yaw_deg`` degrees, unless ``folder`` already holds it: ``folder.json`` names
    the sequence's settings digest, cameras, crf and yaw it was written from. True if written."""
    source = {
        "sequence": str(sequence.root),
        "digest": sequence.meta["generator"]["digest"],
        "cameras": [c.name for c in sequence.cameras],
        "crf": crf,
        "yaw_deg": yaw_deg,
    }
    stamp = Path(folder).with_suffix(".json")
    if stamp.is_file() and Path(folder).is_dir() and read_json_object(stamp) == source:
        return False
    write_recording(sequence, Path(folder), yaw_deg=yaw_deg, crf=crf, progress=progress)
    write_json_atomic(stamp, source)
    return True


def foreground_fraction(run_config: dict, frames: int) -> float:
    """Mean fraction of the image that the run's foreground covers over its first ``frames``
    frames and its cameras (the masks the run tracked against, by its foreground method, from
    its cache)."""
    cfg = OmegaConf.create(run_config)
    sequence = instantiate(cfg.dataset).open(progress=False)
    if "foreground" in cfg:
        foreground = open_foreground(cfg, sequence, cache_dir=cfg.foreground_cache)
    else:  # a run recorded before foreground.method, when the plate was the only foreground
        foreground = Foreground(sequence, instantiate(cfg.background), cache_dir=cfg.foreground_cache)
    fractions = [np.count_nonzero(mask) / mask.size for frame in range(frames) for mask in foreground.masks(frame)]
    return float(np.mean(fractions))


def runs_table(folder: Path) -> pd.DataFrame:
    """One row per run record of the sweep ``folder``: sequence, crf, mean marker error (mm),
    foreground fraction, body height (mm)."""
    store = ResultsStore(folder)
    rows = []
    for run_id in store.run_ids():
        record = store.get(run_id)
        source = store.path(run_id)
        try:
            run_config, summary = record["config"], record["summary"]  # type: ignore[index]
            subject, action = run_config["dataset"]["subject"], run_config["lossy"]["action"]
            crf = int(run_config["lossy"]["crf"])
            error = summary["mean_marker_error_mm"]
        except (KeyError, TypeError) as exc:
            raise DataError(f"{source}: not a run of +experiment=lossy (no {exc})") from None
        rows.append(
            {
                "sequence": f"{subject}_{action}",
                "crf": crf,
                "error_mm": np.nan if error is None else float(error),
                "foreground": foreground_fraction(run_config, int(summary["frames"])),
            }
        )
    if not rows:
        raise DataError(f"no run records in {store.records_dir}: has `make lossy` run into {store.folder}?")
    return pd.DataFrame(rows)


def lossy_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per sequence: the error of the lossless run (the lowest crf), of each other crf, their
    ratio and whether it meets :data:`LOSSY_GOAL`, and each run's foreground fraction (%)."""
    crfs = sorted(int(c) for c in runs.crf.unique())
    if len(crfs) < 2:
        raise DataError(f"the lossy table compares recordings of two crf values at least; the runs hold {crfs}")
    reference, *others = crfs
    means = runs.groupby(["sequence", "crf"]).mean(numeric_only=True)
    error = means["error_mm"].unstack("crf")
    fraction = 100 * means["foreground"].unstack("crf")
    table = pd.DataFrame(index=error.index)
    name = {c: "lossless" if c == 0 else f"crf {c}" for c in crfs}
    for c in crfs:
        table[f"{name[c]} (mm)"] = error[c]
    for c in others:
        table[f"ratio {name[c]}"] = error[c] / error[reference]
    for c in crfs:
        table[f"foreground {name[c]} (%)"] = fraction[c]
    ratios = table[[f"ratio {name[c]}" for c in others]]
    table["goal met"] = np.where((ratios <= LOSSY_GOAL).all(axis=1), "yes", "no")
    return table.rename_axis("Sequence").reset_index()


def _section(runs: pd.DataFrame, what: str, name: str, args) -> str:
    """The lossy table of ``runs`` written to ``args.out/tables/<name>.*`` and printed; returns
    its page section: a title naming ``what`` was tracked and how many sequences met the goal."""
    table = lossy_table(runs)
    met = int((table["goal met"] == "yes").sum())
    title = (
        f"Lossy video, {what}: mean marker error (mm) tracked from nothing on each recording, and the mean "
        f"foreground fraction of its tracked frames; goal: ratio <= {LOSSY_GOAL} to the lossless run (met on "
        f"{met} of {len(table)} sequences)"
    )
    source = f"{len(runs)} runs"
    written = write_table(table, args.out / "tables" / name, title=title, source=source, floatfmt=".2f")
    print(Path(written[1]).read_text(), end="")
    return page_section(Path(written[1]).read_text())


def table_main(args) -> None:
    """``mmocap lossy table``: the table of the sweep ``args.folder`` and, with
    ``args.segmentation``, a second one whose compressed recordings were segmented instead
    (their runs against the same lossless ones); on ``args.page`` if given."""
    runs = runs_table(args.folder)
    sections = {"lossy": _section(runs, "the plate's foreground (Horprasert)", "lossy", args)}
    if args.segmentation is not None:
        reference = runs[runs.crf == runs.crf.min()]
        segmented = runs_table(args.segmentation)
        segmented = segmented[segmented.crf != reference.crf.min()]
        what = "the compressed recordings segmented (foreground.method=segmentation), the lossless ones as above"
        sections["lossy_segmentation"] = _section(pd.concat([reference, segmented]), what, "lossy_segmentation", args)
    if args.page is not None:
        update_page(args.page, args.target, None, sections, order=["lossy", "lossy_segmentation"])
        print(f"written: {args.page}")


def main(argv: list[str], prog: str) -> None:
    """``mmocap lossy prepare [OVERRIDES]`` and ``mmocap lossy table FOLDER``: the recordings of
    ``make lossy`` and its table (module docstring)."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    steps = parser.add_subparsers(dest="step", required=True)
    first = steps.add_parser("prepare", help="render the sequences and write their recordings")
    first.add_argument("overrides", nargs="*", help="Hydra overrides of +experiment=lossy, e.g. scale@lossy=smoke")
    first.add_argument("--progress", action="store_true", help="progress bars")
    last = steps.add_parser("table", help="the table of a lossy sweep's runs")
    last.add_argument("folder", type=Path, help="the sweep folder (its records/)")
    last.add_argument(
        "--out", type=Path, default=Path("outputs"), help="writes OUT/tables/lossy.* (default: %(default)s)"
    )
    last.add_argument("--page", type=Path, help="also put the table on this results page (docs/results/lossy.md)")
    last.add_argument(
        "--segmentation",
        type=Path,
        help="a sweep of the compressed recordings with foreground.method=segmentation: a second table",
    )
    last.add_argument("--target", default="lossy", help="the make target the page's stamp names")
    args = parser.parse_args(argv)
    if args.step == "prepare":
        prepare(args.overrides, progress=args.progress)
    else:
        table_main(args)
