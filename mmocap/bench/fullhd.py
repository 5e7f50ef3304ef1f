"""Full HD at interactive speed (``mmocap bench fullhd``): a full-HD synthetic sequence (S1
walking, 4 cameras, 1920x1080 by default, ``exact`` realism as ``make autostart`` measures
the start) written as a recording (:func:`mmocap.data.recording.reader.write_recording`,
lossless by default: ``crf=0``) into a temporary folder, then tracked from nothing by the
real pipeline, as a user's recording is (no first pose, no body size: the automatic start),
with the default foreground (the plate, Horprasert) and holistic CMA-ES at 1500 evaluations
per frame, once per working scale (``dataset.scale``): at full resolution and at each
reduced scale.

Per run: the automatic start's time, the foreground's and the search's time per frame and
their sum, the mean marker error, and the ratios of error and time to the full-resolution
run of the same bench; whether the run meets the goal (:data:`GOAL_FRAME_SECONDS` per frame,
foreground and search together, at most :data:`GOAL_ERROR_RATIO` times the full-resolution
error, the start within :data:`GOAL_START_SECONDS`). A second table says where each scale's
foreground time goes (:func:`foreground_profile`): decoding the videos, converting and
shrinking the frames, background subtraction, undistortion, and the rest.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from hydra.utils import instantiate

from mmocap.bitmask import ForegroundMask
from mmocap.config import compose
from mmocap.data.recording.reader import write_recording
from mmocap.errors import ConfigError
from mmocap.pipeline import open_foreground, run
from mmocap.validate import check_number

#: the working scales of ``mmocap bench fullhd`` unless ``--scales`` is given (1: the reference)
DEFAULT_SCALES = "1,0.5,0.333"
#: the sequence's size, px (full HD) and frames unless ``--width``, ``--height``, ``--track-frames`` say
FULLHD_WIDTH, FULLHD_HEIGHT, FULLHD_FRAMES = 1920, 1080, 20
#: the recording's H.264 quality unless ``--crf`` says (0: lossless, the rendered pixels)
FULLHD_CRF = 0
#: the search seed of every run
FULLHD_SEED = 0
#: the goal: foreground and search per frame, s ...
GOAL_FRAME_SECONDS = 0.25
#: ... at most this multiple of the full-resolution run's mean marker error ...
GOAL_ERROR_RATIO = 1.1
#: ... and the automatic start within this many seconds
GOAL_START_SECONDS = 30.0
#: the synthetic sequence rendered (its size, frames and folder added)
FULLHD_SEQUENCE = [
    "dataset.subject=S1",
    "dataset.action=walking",
    "dataset.cameras=[C1,C2,C3,BW1]",
    "dataset.all_cameras=[C1,C2,C3,BW1]",
    "realism=exact",
]
#: the run every scale shares, after ``dataset=recording`` and its folder (no recovery
#: searches, whose extra evaluations vary; no foreground cache: each frame's foreground is
#: computed and timed)
FULLHD_RUN = [
    "recovery.enabled=false",
    "overlays=0",
    "progress=false",
    "foreground_cache=null",
    "tracking.evaluations=1500",
    "body.dof=39",
]


def parse_scales(text: str) -> list[float]:
    """``--scales`` '1,0.5,0.333' -> [1.0, 0.5, 0.333], each in (0, 1], 1 among them (the
    run the ratios are against); a ConfigError otherwise."""
    try:
        scales = [float(item) for item in text.split(",") if item.strip()]
    except ValueError:
        scales = []
    if not scales:
        raise ConfigError(f"--scales must be comma-separated fractions in (0, 1], e.g. 1,0.5,0.333, got {text!r}")
    scales = [check_number("--scales", s, 0, 1, low_open=True) for s in scales]
    if 1 not in scales:
        raise ConfigError(f"--scales must include 1, the full-resolution run the ratios are against, got {text!r}")
    return scales


def write_fullhd_recording(folder: Path, width: int, height: int, frames: int, crf: int = FULLHD_CRF) -> Path:
    """Render :data:`FULLHD_SEQUENCE` at ``width`` x ``height`` px, ``frames`` frames, into
    ``folder/data`` and write it as a recording ``folder/recording`` in H.264 of quality
    ``crf`` (0: lossless); returns it."""
    cfg = compose(
        [
            *FULLHD_SEQUENCE,
            f"dataset.root={folder / 'data'}",
            f"dataset.width={width}",
            f"dataset.height={height}",
            f"dataset.frames={frames}",
        ]
    )
    sequence = instantiate(cfg.dataset).open(progress=False)
    return write_recording(sequence, folder / "recording", crf=crf, progress=False)


def run_overrides(recording: Path, scale: float, frames: int, seed: int) -> list[str]:
    """The config overrides of tracking ``recording`` at ``scale``."""
    return [
        "dataset=recording",
        f"dataset.root={recording}",
        f"dataset.scale={scale}",
        *FULLHD_RUN,
        f"tracking.frames={frames}",
        f"seed={seed}",
    ]


def track_at(recording: Path, scale: float, frames: int, seed: int, folder: Path) -> dict:
    """Track ``frames`` frames of ``recording`` from nothing at ``scale`` in a fresh folder
    under ``folder``; one row of :func:`fullhd_tables` (without the ratios), with the
    machine's load (1-minute average of runnable processes) when the run began, since
    the times are wall times."""
    cfg = compose(run_overrides(recording, scale, frames, seed))
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(dir=folder) as run_dir:
        summary = run(cfg, Path(run_dir))
    camera = instantiate(cfg.dataset).open(progress=False).cameras[0]
    row = {
        "scale": scale,
        "width_px": camera.width,
        "height_px": camera.height,
        "start_s": summary["start"]["seconds"],
        "foreground_s_per_frame": summary["foreground_seconds_per_frame"],
        "search_s_per_frame": summary["seconds_per_frame"],
    }
    row["frame_s"] = row["foreground_s_per_frame"] + row["search_s_per_frame"]
    row["mean_marker_error_mm"] = summary["mean_marker_error_mm"]
    row["load_1min"] = load
    print(
        f"fullhd: scale {scale:g} ({camera.width}x{camera.height}): start {row['start_s']:.1f} s, "
        f"foreground {row['foreground_s_per_frame']:.3f} + search {row['search_s_per_frame']:.3f} s per frame, "
        f"{row['mean_marker_error_mm']:.1f} mm",
        flush=True,
    )
    return row


def with_ratios(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` (rows of :func:`track_at`, one at scale 1) with the error and time ratios to the
    scale-1 run and whether each run meets the goal (``goal_met``)."""
    reference = df[df.scale == 1].iloc[0]
    df = df.assign(
        error_ratio=df.mean_marker_error_mm / reference.mean_marker_error_mm,
        time_ratio=df.frame_s / reference.frame_s,
    )
    df["goal_met"] = (
        (df.frame_s <= GOAL_FRAME_SECONDS) & (df.error_ratio <= GOAL_ERROR_RATIO) & (df.start_s <= GOAL_START_SECONDS)
    )
    return df


def foreground_profile(recording: Path, scale: float, frames: int) -> dict:
    """Where the foreground's time goes at ``scale``, s per frame (every camera's), over
    ``frames`` frames after fitting the plate: decoding the videos (``decode_s``), converting
    and shrinking the decoded frames (``shrink_s``), background subtraction with its clean-up
    (``subtract_s``), undistortion (``undistort_s``) and packing the masks' bits (``pack_s``),
    each step as the pipeline's foreground takes it (:meth:`FrameSource.decoded
    <mmocap.data.recording.reader.FrameSource.decoded>` and ``prepared``, the model's
    ``find_person``, the camera's ``undistort_mask``, :class:`~mmocap.bitmask.ForegroundMask`)."""
    cfg = compose(run_overrides(recording, scale, frames, 0))
    sequence = instantiate(cfg.dataset).open(progress=False)
    models = open_foreground(cfg, sequence, cache_dir=None).models  # fit on the plate before timing
    first = int(sequence.meta["start"])
    spent = dict.fromkeys(("decode_s", "shrink_s", "subtract_s", "undistort_s", "pack_s"), 0.0)
    for frame in range(frames):
        for source, offset, camera, model in zip(sequence.sources, sequence.offsets, sequence.cameras, models):
            index = first + frame + offset
            clock = [time.perf_counter()]
            image = source.decoded(index)
            clock.append(time.perf_counter())
            image = source.prepared(image, index)
            clock.append(time.perf_counter())
            mask, _ = model.find_person(image, camera.name)
            clock.append(time.perf_counter())
            mask = camera.undistort_mask(mask)
            clock.append(time.perf_counter())
            ForegroundMask(mask)
            clock.append(time.perf_counter())
            for name, seconds in zip(spent, np.diff(clock)):
                spent[name] += seconds
    return {"scale": scale, **{name: seconds / frames for name, seconds in spent.items()}}


def fullhd_tables(
    scales: list[float], width: int, height: int, frames: int, seed: int, out: Path, crf: int = FULLHD_CRF
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The recording (``width`` x ``height`` px, ``frames`` frames, H.264 quality ``crf``) tracked at each of
    ``scales`` (one of them 1) with search seed ``seed``, one run after the other: the runs'
    table (:func:`track_at`, :func:`with_ratios`) and the foregrounds' profile
    (:func:`foreground_profile`), one row per scale each."""
    with tempfile.TemporaryDirectory(dir=out) as folder:
        print(f"fullhd: rendering {width}x{height}, {frames} frames, as a recording (crf {crf})", flush=True)
        recording = write_fullhd_recording(Path(folder), width, height, frames, crf)
        runs = pd.DataFrame([track_at(recording, scale, frames, seed, Path(folder)) for scale in scales])
        profile = pd.DataFrame([foreground_profile(recording, scale, frames) for scale in scales])
    profile["total_s"] = profile.drop(columns="scale").sum(axis=1)
    return with_ratios(runs), profile
