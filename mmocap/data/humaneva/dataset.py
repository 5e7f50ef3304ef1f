"""One HumanEva-I trial opened for tracking: :class:`HumanEvaDataset`, the Hydra component
(``conf/dataset/humaneva.yaml``), and the :class:`HumanEvaSequence` it opens.

Time: the first selected camera is the reference: frame k of the opened sequence is its
image ``start + k``; every other camera shows its image nearest the same mocap time, through
its own ``.ofs`` (:mod:`mmocap.data.humaneva.synchronisation`), and the ground truth is the
markers at that mocap time (:func:`mmocap.data.humaneva.mocap.sample_mocap`).  ``split``
selects one of the toolbox's partitions (:data:`mmocap.data.humaneva.layout.PARTITIONS`),
else the sequence runs from the first image at or after toolbox frame
:data:`~mmocap.data.humaneva.layout.TOOLBOX_FIRST_FRAME` (6) at which every mapped marker is
present to the end of the videos.

Initialisation (``x0``): either read from a file of 51 numbers (mm, rad), or fitted to the
first frame's markers by :func:`mmocap.body.inverse_kinematics.fit_pose` (rigid alignment of
the torso markers, then bounded least squares over the joint angles with a small pull towards
the rest pose).
"""

from __future__ import annotations

import io
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from mmocap.body.inverse_kinematics import fit_pose
from mmocap.body.model import MARKER_NAMES, BodyModel
from mmocap.body.skeleton import dof_mask
from mmocap.camera import Camera
from mmocap.data.humaneva.frames import FrameSource, open_frames
from mmocap.data.humaneva.layout import (
    ACTIONS,
    CAMERAS,
    PARTITIONS,
    SPLITS,
    SUBJECTS,
    TOOLBOX_FIRST_FRAME,
    TRIALS,
    is_colour,
)
from mmocap.data.humaneva.mocap import check_marker_map, default_marker_map, model_markers, read_mocap, sample_mocap
from mmocap.data.humaneva.synchronisation import SyncOffsets, toolbox_frame_offsets
from mmocap.data.sequence import SequenceBase
from mmocap.errors import ConfigError, DataError
from mmocap.io import read_lines_file


def read_pose_file(path: Path) -> np.ndarray:
    """(51,) pose (mm, rad) from a .npy file or a text file of 51 numbers; a DataError naming
    the file if it is not one, or if the text file's last line has no line end (it may be cut
    inside its last number: :func:`mmocap.io.check_whole_lines`)."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"x0 file not found: {path}")
    text = None if path.suffix == ".npy" else read_lines_file(path, f"x0 file {path}")
    try:
        x = np.load(path) if text is None else np.loadtxt(io.StringIO(text), delimiter=None, ndmin=1)
    except Exception as exc:  # numpy raises many types for a damaged .npy header or a text that is not numbers
        raise DataError(f"x0 file {path} is not a list of numbers: {' '.join(str(exc).split())}") from None
    x = np.asarray(x, dtype=np.float64).ravel()
    if x.shape != (51,) or not np.all(np.isfinite(x)):
        raise DataError(f"x0 file {path} must hold 51 finite numbers (mm, rad), got {x.size}")
    return x


@dataclass
class HumanEvaSequence(SequenceBase):
    """One HumanEva-I trial opened for reading (see the module docstring for frame timing).

    Extra attributes: ``sources`` (one :class:`FrameSource` per camera), ``image_index``
    (frames, cameras) 1-based image per frame and camera, ``truth`` (frames, 15, 3) mm,
    ``background_sources`` per camera name and ``background_frames`` taken from them.
    """

    sources: list[FrameSource] = field(default_factory=list)
    image_index: np.ndarray = field(default_factory=lambda: np.empty((0, 0), int))
    truth: np.ndarray = field(default_factory=lambda: np.empty((0, len(MARKER_NAMES), 3)))
    background_sources: dict = field(default_factory=dict)
    background_frames: int = 50

    def images(self, frame: int) -> list[np.ndarray]:
        self.check_frame(frame)
        return [src.read(int(i)) for src, i in zip(self.sources, self.image_index[frame])]

    def background(self, camera: Camera) -> list[np.ndarray]:
        sources = self.background_sources[camera.name]
        total = sum(s.count for s in sources)
        picks = np.unique(np.linspace(0, total - 1, min(total, self.background_frames)).round().astype(int))
        starts = np.cumsum([0] + [s.count for s in sources])
        frames = []
        for p in picks:
            k = int(np.searchsorted(starts, p, side="right") - 1)
            frames.append(sources[k].read(int(p - starts[k]) + 1))
        return frames

    def markers(self) -> np.ndarray:
        return self.truth.copy()

    @property
    def markers_source(self) -> str:
        return str(self.root / "Mocap_Data" / f"{self.meta['action']}_{self.meta['trial']}.mat")


class HumanEvaDataset:
    """Hydra component: one trial of HumanEva-I under ``root``.

    Args:
        root: the folder holding ``S1``..``S4`` and ``Background``.
        subject, action, trial: e.g. ``"S1"``, ``"Walking"``, 1.
        cameras: camera names; the first is the timing reference.
        marker_map: body-model marker name -> mocap labels (their centroid is the marker).
        split: None, or the toolbox partition to read (:data:`SPLITS`): exactly its frames of
            :data:`PARTITIONS` for this subject, action and trial.
        start_frame: 1-based image of the first camera to start at, within ``split`` if one is
            given; None = the split's first frame, or without a split the first image from
            toolbox frame :data:`TOOLBOX_FIRST_FRAME` on at which every mapped marker is
            present (the first synchronised one without mocap).
        frames: frames to read at most; None = up to the end of the split, else of the
            shortest video.
        fps: video frame rate (HumanEva-I: 60).
        background_frames: frames taken, evenly spaced, from each camera's background videos.
        min_background_frames: fewer background frames than this is an error.
        x0: file with the first frame's pose (51 numbers, mm and rad); None = fit it to the
            first frame's markers (:func:`fit_pose`) with the ``x0_dof`` model.
        x0_dof: degrees of freedom of the model fitted for x0 (28, 39 or 51).
    """

    def __init__(
        self,
        root=None,
        subject: str = "S1",
        action: str = "Walking",
        trial: int = 1,
        cameras=("C1", "C2", "C3", "BW1"),
        marker_map: dict | None = None,
        split: str | None = None,
        start_frame: int | None = None,
        frames: int | None = None,
        fps: float = 60.0,
        background_frames: int = 50,
        min_background_frames: int = 2,
        x0=None,
        x0_dof: int = 39,
    ):
        if root is None:
            raise ConfigError("dataset.root must be set to the HumanEva-I folder (the one holding S1..S4)")
        checks = (("subject", subject, SUBJECTS), ("action", action, ACTIONS), ("trial", trial, TRIALS))
        for name, value, known in checks:
            if value not in known:
                raise ConfigError(f"unknown HumanEva-I {name} {value!r}; known: {', '.join(map(str, known))}")
        cameras = list(cameras)
        unknown = [c for c in cameras if c not in CAMERAS]
        if unknown or not cameras:
            raise ConfigError(f"dataset.cameras must name HumanEva-I cameras ({', '.join(CAMERAS)}), got {cameras}")
        if split is not None and split not in SPLITS:
            raise ConfigError(f"dataset.split must be null or one of {', '.join(SPLITS)}, got {split!r}")
        partitions = PARTITIONS.get((subject, action, int(trial)), {})
        if split is not None and split not in partitions:
            raise ConfigError(
                f"dataset.split {split!r} has no frames of {subject} {action}_{trial}: the HumanEva-I "
                f"toolbox's partitions of its video are {', '.join(partitions) or 'none'}; set "
                "dataset.split to one of them or to null"
            )
        if start_frame is not None and start_frame < 1:
            raise ConfigError(f"dataset.start_frame must be >= 1 (1-based), got {start_frame}")
        if frames is not None and frames < 1:
            raise ConfigError(f"dataset.frames must be >= 1, got {frames}")
        if min_background_frames < 2 or background_frames < min_background_frames:
            raise ConfigError(
                "dataset.background_frames must be >= dataset.min_background_frames >= 2, "
                f"got {background_frames} and {min_background_frames}"
            )
        self.root, self.subject, self.action, self.trial = Path(root), subject, action, int(trial)
        self.cameras = cameras
        self.marker_map = check_marker_map(default_marker_map() if marker_map is None else marker_map)
        self.split, self.start_frame, self.frames, self.fps = split, start_frame, frames, float(fps)
        self.background_frames, self.min_background_frames = int(background_frames), int(min_background_frames)
        self.x0, self.x0_mask = x0, dof_mask(int(x0_dof))

    @property
    def stem(self) -> str:
        """``<action>_<trial>``, the trial's name in the dataset's file names."""
        return f"{self.action}_{self.trial}"

    def open(self, progress: bool = True) -> HumanEvaSequence:
        """The trial opened for tracking (its cameras, synchronisation and markers), a DataError
        naming the missing file otherwise; ``progress`` shows a progress bar while opening."""
        folder = self.root / self.subject
        if not folder.is_dir():
            raise DataError(f"HumanEva-I subject folder not found: {folder}")
        sources, syncs, cams = [], [], []
        for name in tqdm(self.cameras, desc=f"open {self.subject} {self.stem}", unit="camera", disable=not progress):
            source = open_frames(folder / "Image_Data", f"{self.stem}_({name})", name)
            sources.append(source)
            syncs.append(SyncOffsets.load(folder / "Sync_Data" / f"{self.stem}_({name}).ofs"))
            cams.append(
                Camera.load_cal(
                    folder / "Calibration_Data" / f"{name}.cal",
                    source.width,  # type: ignore[arg-type]
                    source.height,  # type: ignore[arg-type]
                    source.colour,
                )
            )
        for name, source, sync in zip(self.cameras, sources, syncs):
            if sync.image_start > source.count:
                raise DataError(
                    f"sync file {folder / 'Sync_Data' / f'{self.stem}_({name}).ofs'} starts at "
                    f"image {sync.image_start:g}, past the end of {source.path} "
                    f"({source.count} images)"
                )
        mocap = self._mocap(folder)
        index, truth = self._timing(folder, sources, syncs, mocap)
        x0 = self._initial_pose(truth[0], folder, mocap)
        backgrounds = {c.name: self._background_sources(c.name) for c in cams}
        meta = {
            "format": "humaneva-i",
            "subject": self.subject,
            "action": self.action,
            "trial": self.trial,
            "split": self.split,
            "fps": self.fps,
            "frames": len(index),
            "cameras": self.cameras,
            "marker_names": list(MARKER_NAMES),
            "x0": None if x0 is None else x0.tolist(),
            "first_image": int(index[0, 0]),
            "marker_map": self.marker_map,
            "units": {"length": "mm", "angle": "rad"},
        }
        return HumanEvaSequence(
            folder,
            meta,
            cams,
            sources=sources,
            image_index=index,
            truth=truth,
            background_sources=backgrounds,
            background_frames=self.background_frames,
        )

    def _mocap(self, folder: Path) -> np.ndarray | None:
        """(mocap frames, 15, 3) mm model markers, or None when the trial has no mocap file."""
        path = folder / "Mocap_Data" / f"{self.stem}.mat"
        if not path.is_file():
            return None
        labels, markers = read_mocap(path)
        return model_markers(labels, markers, self.marker_map, path)

    def _timing(self, folder, sources, syncs, mocap):
        """(frames, cameras) 1-based image indices and (frames, 15, 3) mm truth."""
        ref = sources[0]
        candidates = np.arange(1, ref.count + 1)
        mocap_index = syncs[0].mocap_index(candidates)
        per_camera = np.stack([np.rint(s.image_index(mocap_index)).astype(int) for s in syncs], axis=1)
        counts = np.array([s.count for s in sources])
        in_videos = np.all((per_camera >= 1) & (per_camera <= counts), axis=1)
        for c, name in enumerate(self.cameras):
            if not np.any((per_camera[:, c] >= 1) & (per_camera[:, c] <= counts[c])):
                raise DataError(
                    f"sync file {folder / 'Sync_Data' / f'{self.stem}_({name}).ofs'}: no image "
                    f"of {sources[c].path} falls within the reference camera's video"
                )
        offset = self._toolbox_offset(folder) - 1  # toolbox frame F is image F + offset of the reference
        if self.split is None:
            first, last = TOOLBOX_FIRST_FRAME + offset, ref.count
        else:
            span = PARTITIONS[(self.subject, self.action, self.trial)][self.split]
            first, last = (f + offset for f in span)
            if last > ref.count or not in_videos[first - 1 : last].all():
                raise DataError(
                    f"dataset.split {self.split!r} is images {first}..{last} of {ref.path} (toolbox "
                    f"frames {span[0]}..{span[1]}), not all of them in every camera's video"
                )
        if self.start_frame is not None:
            start = self.start_frame
            if self.split is not None and not first <= start <= last:
                raise ConfigError(
                    f"dataset.start_frame {start} is outside dataset.split {self.split!r} of "
                    f"{self.subject} {self.stem}, images {first}..{last} of {self.cameras[0]}; "
                    "give a start_frame in that range, or null"
                )
            if start > ref.count or not in_videos[start - 1]:
                raise DataError(
                    f"dataset.start_frame {start} is not an image of every camera "
                    f"(the {self.cameras[0]} video {ref.path} has {ref.count})"
                )
        elif self.split is not None:
            start = first
        else:
            usable = in_videos & (candidates >= first)
            if mocap is not None:  # else (trial 2) the first image of every camera
                usable &= ~np.isnan(sample_mocap(mocap, mocap_index)).any(axis=(1, 2))
            if not usable.any():
                markers = (
                    ""
                    if mocap is None
                    else f" with every mapped marker present in {folder / 'Mocap_Data' / f'{self.stem}.mat'}"
                )
                raise DataError(
                    f"no image of {ref.path} from image {first} (toolbox frame {TOOLBOX_FIRST_FRAME}) "
                    f"on is in every camera's video{markers}"
                )
            start = int(candidates[np.argmax(usable)])
        run = in_videos[start - 1 : last]
        n = int(np.argmin(run)) if not run.all() else len(run)
        if self.frames is not None:
            n = min(n, self.frames)
        rows = slice(start - 1, start - 1 + n)
        truth = np.full((n, len(MARKER_NAMES), 3), np.nan) if mocap is None else sample_mocap(mocap, mocap_index[rows])
        return per_camera[rows], truth

    def _toolbox_offset(self, folder: Path) -> int:
        """The reference camera's image at toolbox frame 1, from the ``.ofs`` files of every
        HumanEva-I camera in ``Sync_Data`` (:func:`toolbox_frame_offsets`)."""
        paths = {c: folder / "Sync_Data" / f"{self.stem}_({c}).ofs" for c in CAMERAS}
        present = [c for c, path in paths.items() if path.is_file()]
        offsets = toolbox_frame_offsets([SyncOffsets.load(paths[c]) for c in present])
        return int(offsets[present.index(self.cameras[0])])

    def _initial_pose(self, first_markers: np.ndarray, folder: Path, mocap) -> np.ndarray | None:
        """``dataset.x0``, else the pose fitted to the first frame's markers; None without
        mocap (trial 2: the automatic start finds it)."""
        if self.x0 is not None:
            return read_pose_file(self.x0)
        if mocap is None:
            return None
        if np.isnan(first_markers).any():
            missing = [n for n, row in zip(MARKER_NAMES, first_markers) if np.isnan(row).any()]
            raise DataError(
                f"{folder / 'Mocap_Data' / f'{self.stem}.mat'}: markers {', '.join(missing)} are "
                "missing at the first frame; choose another dataset.start_frame or give dataset.x0"
            )
        body = BodyModel(self.subject, dof=int(self.x0_mask.sum()), vertices=None)
        return fit_pose(body, first_markers, self.x0_mask)

    def _background_sources(self, camera: str) -> list[FrameSource]:
        folder = self.root / "Background"
        pattern = re.compile(rf"Background_(\d+)_\({camera}\)(\.avi)?$", re.IGNORECASE)
        found = {p: pattern.match(p.name) for p in folder.glob("Background_*")} if folder.is_dir() else {}
        paths = sorted(
            (p for p, m in found.items() if m and (m.group(2) or p.is_dir())),
            key=lambda p: int(found[p].group(1)),  # type: ignore[union-attr]  # matched
        )
        if not paths:
            raise DataError(f"camera {camera}: no background video {folder / f'Background_<k>_({camera}).avi'}")
        sources = [FrameSource(p, camera, is_colour(camera)) for p in paths]
        total = sum(s.count for s in sources)
        if total < self.min_background_frames:
            raise DataError(
                f"camera {camera}: background {', '.join(str(p) for p in paths)} holds {total} "
                f"frames, the background model needs at least {self.min_background_frames}"
            )
        return sources
