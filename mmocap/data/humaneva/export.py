"""A synthetic sequence folder (:mod:`mmocap.data.sequence`) written in the HumanEva-I layout
(:mod:`mmocap.data.humaneva.layout`): ``mmocap export-humaneva``."""

from __future__ import annotations

import contextlib
import os
import shutil
import uuid
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from mmocap.body.model import MARKER_NAMES
from mmocap.data.humaneva.layout import CAMERAS, TOOLBOX_FIRST_FRAME, TRIALS
from mmocap.data.humaneva.mocap import check_marker_map, default_marker_map, sample_mocap, write_mocap
from mmocap.data.humaneva.synchronisation import SyncOffsets
from mmocap.data.sequence import Sequence, read_image
from mmocap.errors import ConfigError
from mmocap.io import write_image, writing
from mmocap.video import write_video

# The synthetic generator's actions under their HumanEva-I names.
SYNTHETIC_ACTIONS = {"walking": "Walking", "gestures": "Gestures", "boxing": "Box"}


def upsample(markers: np.ndarray, factor: int) -> np.ndarray:
    """(F, M, 3) at the video rate -> ((F - 1) * factor + 1, M, 3), linearly interpolated."""
    return sample_mocap(markers, 1 + np.arange((len(markers) - 1) * factor + 1) / factor)


def export(
    sequence_root,
    out,
    marker_map: dict | None = None,
    trial: int = 1,
    images: str = "avi",
    mocap_lead: int = 4,
    progress: bool = True,
) -> Path:
    """Write a synthetic sequence folder (:mod:`mmocap.data.sequence`) in the HumanEva-I layout.

    Under ``out``: ``<subject>/Calibration_Data``, ``Image_Data`` (lossless FFV1 .avi, or PNG
    folders for ``images="png"``: ``TOOLBOX_FIRST_FRAME - 1`` copies of the first frame, as
    the dataset's videos repeat theirs, then the sequence, which thus starts at the toolbox's
    first frame), ``Sync_Data`` (IM_ST = 1, MC_ST = 1 + mocap_lead, MC_SC = 2),
    ``Mocap_Data/<Action>_<trial>.mat`` (markers at 120 Hz, interpolated from the video rate,
    after ``mocap_lead`` frames with every marker missing and the first frame's markers held
    over the copies; each label of ``marker_map`` at its marker's position) and
    ``Background/Background_1_(<cam>).avi``.
    Returns ``out``. The export completes or leaves ``out`` as it was: a failure to write (a
    :class:`~mmocap.io.WriteError` naming ``out``: a full disk, a read-only folder, a file
    where ``out`` should be) leaves no part of it.
    """
    if images not in ("avi", "png"):
        raise ConfigError(f"images must be 'avi' or 'png', got {images!r}")
    if mocap_lead < 0:
        raise ConfigError(f"mocap_lead must be >= 0, got {mocap_lead}")
    if trial not in TRIALS:
        raise ConfigError(f"unknown HumanEva-I trial {trial!r}; known: {', '.join(map(str, TRIALS))}")
    seq = Sequence.open(sequence_root)
    action = SYNTHETIC_ACTIONS.get(seq.meta["action"])
    if action is None:
        raise ConfigError(
            f"action '{seq.meta['action']}' of {seq.root} has no HumanEva-I name "
            f"(known: {', '.join(SYNTHETIC_ACTIONS)})"
        )
    unknown = [c.name for c in seq.cameras if c.name not in CAMERAS]
    if unknown:
        raise ConfigError(f"cameras {', '.join(unknown)} of {seq.root} are not HumanEva-I cameras")
    marker_map = check_marker_map(default_marker_map() if marker_map is None else marker_map)
    out = Path(out)
    stem = f"{action}_{trial}"
    sync = SyncOffsets(1.0, 1.0 + mocap_lead, 2.0)
    lead_in = TOOLBOX_FIRST_FRAME - 1
    subject = Path(seq.subject)
    with _staged_export(out) as staging:
        for cam in tqdm(seq.cameras, desc=f"export {seq.subject} {stem}", unit="camera", disable=not progress):
            cam.save_cal(staging.place(subject / "Calibration_Data" / f"{cam.name}.cal"))
            sync.save(staging.place(subject / "Sync_Data" / f"{stem}_({cam.name}).ofs"))
            frames = (
                read_image(seq.root / "images" / cam.name / f"{f:06d}.png", cam)
                for f in [0] * lead_in + list(range(seq.n_frames))
            )
            video = subject / "Image_Data" / f"{stem}_({cam.name}).avi"
            folder = video.with_suffix("")  # the same images as PNG files; a reader takes the video first
            if images == "avi":
                write_video(staging.place(video, replaces=folder), frames, seq.fps, crf=0)
            else:
                target = staging.place(folder, replaces=video)
                for f, image in enumerate(frames):
                    write_image(target / f"{f + 1:06d}.png", image)
            write_video(
                staging.place(Path("Background") / f"Background_1_({cam.name}).avi"),
                seq.background(cam),
                seq.fps,
                crf=0,
            )
        truth = upsample(seq.markers(), int(sync.mocap_scale))
        truth = np.concatenate(
            [
                np.full((mocap_lead,) + truth.shape[1:], np.nan),
                np.repeat(truth[:1], lead_in * int(sync.mocap_scale), axis=0),
                truth,
            ]
        )
        labels = [label for name in MARKER_NAMES for label in marker_map[name]]
        columns = [m for m, name in enumerate(MARKER_NAMES) for _ in marker_map[name]]
        write_mocap(staging.place(subject / "Mocap_Data" / f"{stem}.mat"), labels, truth[:, columns])
    return out


class _Staging:
    """The files of one export, written under a temporary folder inside ``out`` and moved
    into place once every one is written."""

    def __init__(self, out: Path):
        self.out = out
        self.folder = out / f".export-{uuid.uuid4().hex[:12]}.tmp"
        self.entries: list[tuple[Path, Path | None]] = []

    def place(self, relative: Path, replaces: Path | None = None) -> Path:
        """Where to write ``out/relative`` (a file, or a folder of files) for now; its folder
        is made. ``replaces``: another entry under ``out`` that this one makes stale (an
        image folder and a video of the same images), removed when this one moves in."""
        self.entries.append((relative, replaces))
        path = self.folder / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        return path

    def move_into_place(self) -> None:
        """Every entry to its place under ``out``, over a file of an earlier export there; a
        folder there, and the entry it replaces, are removed first."""
        for relative, replaces in self.entries:
            target = self.out / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            stale = [] if replaces is None else [self.out / replaces]
            for path in [target, *stale]:
                if path.is_dir():
                    shutil.rmtree(path)
                elif path in stale:
                    path.unlink(missing_ok=True)
            os.replace(self.folder / relative, target)


@contextlib.contextmanager
def _staged_export(out: Path) -> Iterator[_Staging]:
    """An export that completes or leaves ``out`` as it was: its files are written into a
    temporary folder inside ``out`` and moved into place at the end; on an error the folder
    is removed (and ``out`` too, if the export made it). A file-system fault is a
    :class:`~mmocap.io.WriteError` naming ``out``, as the temporary paths mean nothing to
    the user."""
    made_out = not out.exists()
    staging = _Staging(out)
    try:
        with writing(out, rename=True):
            staging.folder.mkdir(parents=True)
            yield staging
            staging.move_into_place()
    except BaseException:
        if made_out:
            shutil.rmtree(out, ignore_errors=True)
        raise
    finally:
        shutil.rmtree(staging.folder, ignore_errors=True)
