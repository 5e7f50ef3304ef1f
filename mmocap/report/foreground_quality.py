"""Foreground quality: precision, recall and IoU of background models against true silhouettes.

Each background method is fit per camera on the sequence's background frames and applied to
every frame; its masks (in the image's own, distorted geometry, before undistortion) are
compared with the silhouettes the synthetic generator writes. The counts are pooled over
frames: precision = TP / (TP + FP), recall = TP / (TP + FN), IoU = TP / (TP + FP + FN).

Command line (``make foreground``)::

    mmocap foreground-quality [--methods horprasert,gaussian,mog2,knn]
        [--csv outputs/tables/foreground.csv] [--md outputs/tables/foreground.md] [overrides]

With ``--crf 0,16,23,28`` (``make foreground-crf``) the sequence's cameras are first written
as recordings at each H.264 quality (``mmocap to-recording --crf``, under ``--recordings``),
and each method is fit on the recording's plate and applied to its decoded frames, as a
tracking run of that recording does; the table then has one row per crf and method, the
cameras pooled (and one per camera in the CSV).

``overrides`` are Hydra overrides of ``conf/config.yaml`` (``dataset.action=boxing``,
``dataset.cameras=[C1,BW1]``); each method is ``background=<method>`` composed with them, but
``segmentation``: person segmentation (``foreground.segmentation``), which ignores the plate.
Before anything is computed: an empty or unknown method, and a ``--csv`` or ``--md`` that is a
folder or cannot be written, end the command with one line; a method named twice counts once.
A true silhouette of another size than its image is an error naming the camera and frame.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd
from hydra.errors import ConfigCompositionException
from hydra.utils import instantiate
from tqdm.auto import tqdm

from mmocap import config
from mmocap.data.recording.reader import RecordingDataset
from mmocap.errors import ConfigError, DataError
from mmocap.io import check_writable_folder, write_text_atomic
from mmocap.report.lossy import ensure_recording
from mmocap.video import CRF_RANGE

METHODS = ("horprasert", "gaussian", "mog2", "knn")
#: the name in ``--methods`` of person segmentation (``foreground.segmentation``, no plate)
SEGMENTATION = "segmentation"
COLUMNS = ["method", "camera", "precision", "recall", "iou"]


def confusion(mask: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(H, W) bool mask and truth -> (3,) int64 counts TP, FP, FN."""
    tp = np.count_nonzero(mask & truth)
    return np.array([tp, np.count_nonzero(mask) - tp, np.count_nonzero(truth) - tp], np.int64)


def scores(counts: np.ndarray) -> tuple[float, float, float]:
    """(3,) TP, FP, FN -> precision, recall, IoU (NaN where undefined)."""
    tp, fp, fn = (float(c) for c in counts)
    ratio = lambda a, b: a / b if b else float("nan")  # noqa: E731
    return ratio(tp, tp + fp), ratio(tp, tp + fn), ratio(tp, tp + fp + fn)


def evaluate(sequence, make_background, frames=None, progress: bool = False, label: str = "") -> np.ndarray:
    """(C, 3) pooled TP, FP, FN per camera of ``sequence`` for one factory of foreground
    models: a background model's (fit on the plate) or the person segmenter's.

    ``frames``: iterable of frame indices (default: all).
    """
    frames = range(sequence.n_frames) if frames is None else list(frames)
    models = [make_background() for _ in sequence.cameras]
    for cam, model in zip(sequence.cameras, models):
        if model.needs_plate:
            model.fit(sequence.background(cam), name=cam.name)
    counts = np.zeros((len(sequence.cameras), 3), np.int64)
    for frame in tqdm(frames, desc=f"foreground {label}".strip(), unit="frame", disable=not progress):
        for c, (cam, model, image) in enumerate(zip(sequence.cameras, models, sequence.images(frame))):
            mask, truth = model.find_person(image, name=cam.name)[0], sequence.silhouette(frame, cam)
            if truth.shape != mask.shape:
                raise DataError(
                    f"camera {cam.name}, frame {frame}: the true silhouette is {truth.shape[1]}x"
                    f"{truth.shape[0]} px but the image {mask.shape[1]}x{mask.shape[0]} px "
                    f"(under {sequence.root / 'silhouettes' / cam.name}); re-render the sequence"
                )
            counts[c] += confusion(mask, truth)
    return counts


def quality_table(sequence, factories: dict, frames=None, progress: bool = False) -> pd.DataFrame:
    """One row per method and camera, then one per method over all cameras ("all")."""
    rows = []
    for method, make_background in factories.items():
        counts = evaluate(sequence, make_background, frames, progress, label=method)
        for cam, c in zip(sequence.cameras, counts):
            rows.append([method, cam.name, *scores(c)])
        rows.append([method, "all", *scores(counts.sum(axis=0))])
    return pd.DataFrame(rows, columns=COLUMNS)


class Recorded:
    """A sequence as a recording of it reads: images and plate decoded from the recording's
    videos, the true silhouettes the sequence's own (the recording's pixels are the
    sequence's, whatever turn its calibration's world was given)."""

    def __init__(self, sequence, recording):
        self.truth, self.recording = sequence, recording
        self.cameras, self.n_frames, self.root = recording.cameras, recording.n_frames, sequence.root
        self._true_camera = {cam.name: cam for cam in sequence.cameras}

    def background(self, camera) -> list[np.ndarray]:
        return self.recording.background(camera)

    def images(self, frame: int) -> list[np.ndarray]:
        return self.recording.images(frame)

    def silhouette(self, frame: int, camera) -> np.ndarray:
        return self.truth.silhouette(frame, self._true_camera[camera.name])


def crf_table(sequence, factories: dict, crfs: list[int], recordings: Path, progress: bool = False) -> pd.DataFrame:
    """One row per crf, method and camera (then "all" cameras) of ``sequence`` written as a
    recording at each crf into ``recordings/<subject>_<action>_crf<crf>``."""
    tables = []
    for crf in crfs:
        folder = recordings / f"{sequence.subject}_{sequence.meta.get('action')}_crf{crf}"
        ensure_recording(sequence, folder, crf, progress=progress)
        recording = RecordingDataset(str(folder), background_frames=len(sequence.background(sequence.cameras[0])))
        recorded = Recorded(sequence, recording.open(progress=False))
        tables.append(quality_table(recorded, factories, progress=progress).assign(crf=crf))
    return pd.concat(tables, ignore_index=True)[["crf", *COLUMNS]]


def crf_markdown(table: pd.DataFrame) -> str:
    """The table of :func:`crf_table` with one row per crf and one column per method:
    ``P / R / IoU`` over all cameras."""
    pooled = table[table.camera == "all"]
    methods = list(dict.fromkeys(pooled["method"]))
    head = "| crf | " + " | ".join(f"{m} P / R / IoU" for m in methods) + " |"
    rule = "| --- |" + " --- |" * len(methods)
    body = []
    for crf, rows in pooled.groupby("crf", sort=True):
        cells = rows.set_index("method").loc[methods]
        body.append(
            f"| {crf}{' (lossless)' if crf == 0 else ''} | "
            + " | ".join(f"{p:.3f} / {r:.3f} / {i:.3f}" for p, r, i in cells[["precision", "recall", "iou"]].to_numpy())
            + " |"
        )
    return "\n".join([head, rule, *body]) + "\n"


def to_markdown(table: pd.DataFrame) -> str:
    """The table with one column per method: ``P / R / IoU`` per camera."""
    cells = table.assign(
        cell=[
            f"{p:.3f} / {r:.3f} / {i:.3f}" for p, r, i in table[["precision", "recall", "iou"]].itertuples(index=False)
        ]
    )
    wide = cells.pivot(index="camera", columns="method", values="cell")
    wide = wide.loc[list(dict.fromkeys(table["camera"])), list(dict.fromkeys(table["method"]))]
    head = "| camera | " + " | ".join(f"{m} P / R / IoU" for m in wide.columns) + " |"
    rule = "| --- |" + " --- |" * len(wide.columns)
    body = [f"| {cam} | " + " | ".join(row) + " |" for cam, row in zip(wide.index, wide.to_numpy())]
    return "\n".join([head, rule, *body]) + "\n"


def _crfs(text: str) -> list[int]:
    """``"0,16,23"`` -> [0, 16, 23]; a ConfigError naming --crf otherwise."""
    try:
        crfs = [int(item) for item in text.split(",")]
    except ValueError:
        crfs = []
    low, high = CRF_RANGE
    if not crfs or any(not low <= crf <= high for crf in crfs):
        raise ConfigError(
            f"--crf {text!r}: give H.264 qualities from {low} (lossless) to {high}, separated by commas, e.g. 0,23"
        )
    return list(dict.fromkeys(crfs))


def main(argv: list[str], prog: str) -> None:
    """``mmocap foreground-quality [--methods ...] [OVERRIDES]``: print and write the precision,
    recall and IoU of each background method per camera."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument(
        "--methods",
        default=",".join(METHODS),
        help="comma-separated background configs (conf/background/*.yaml), and segmentation",
    )
    parser.add_argument("--csv", type=Path, default=Path("outputs/tables/foreground.csv"))
    parser.add_argument("--md", type=Path, default=Path("outputs/tables/foreground.md"))
    parser.add_argument("--crf", default=None, help="H.264 qualities of recordings to measure on, e.g. 0,16,23,28")
    parser.add_argument(
        "--recordings",
        type=Path,
        default=Path("outputs/recordings/foreground"),
        help="folder of the recordings --crf writes (default: %(default)s)",
    )
    parser.add_argument("overrides", nargs="*", help="Hydra overrides, e.g. dataset.action=boxing")
    args = parser.parse_intermixed_args(argv)
    crfs = None if args.crf is None else _crfs(args.crf)
    methods = list(dict.fromkeys(m.strip() for m in args.methods.split(",")))
    if "" in methods:
        raise ConfigError(
            f"--methods {args.methods!r} has an empty name; give comma-separated "
            f"background configs, e.g. {','.join(METHODS)}"
        )
    for option, path in (("--csv", args.csv), ("--md", args.md)):
        if path.is_dir():
            raise ConfigError(f"{option} {path} is a folder; give the file to write, e.g. {path / 'foreground'}")
        check_writable_folder(path.parent)

    configs = {}
    for m in methods:
        try:
            configs[m] = config.compose([*args.overrides, *([] if m == SEGMENTATION else [f"background={m}"])])
        except ConfigCompositionException as exc:
            raise ConfigError(
                f"background={m}: {str(exc).splitlines()[0]} (the overrides apply to every method of --methods)"
            ) from None
    cfg = next(iter(configs.values()))
    sequence = instantiate(cfg.dataset).open(progress=cfg.progress)
    if not (sequence.root / "silhouettes").is_dir():
        raise DataError(f"sequence {sequence.root} has no true silhouettes to compare with")
    factories = {
        m: instantiate(c.foreground.segmentation if m == SEGMENTATION else c.background) for m, c in configs.items()
    }
    what = f"{sequence.subject} {sequence.meta.get('action')} ({sequence.n_frames} frames"
    if crfs is None:
        table = quality_table(sequence, factories, progress=cfg.progress)
        text = f"Foreground quality on {what}): precision / recall / IoU against the true silhouettes\n\n"
        text += to_markdown(table)
    else:
        table = crf_table(sequence, factories, crfs, args.recordings, progress=cfg.progress)
        text = (
            f"Foreground quality on {what}, cameras {', '.join(c.name for c in sequence.cameras)}) written as H.264 "
            "recordings at each crf: precision / recall / IoU against the true silhouettes, all cameras pooled\n\n"
        )
        text += crf_markdown(table)
    write_text_atomic(args.csv, table.to_csv(index=False, float_format="%.4f"))
    write_text_atomic(args.md, text)
    print(text, end="")
