"""A user's own multi-camera recording: its folder layout, reader and checker, and a writer.

A recording folder holds::

    calibration.yml          every camera in one file, in any format of
                             mmocap.data.calibration (OpenCV FileStorage YAML/XML/JSON,
                             anipose / Pose2Sim TOML), or a folder calibration/ of
                             per-camera files; dataset.calibration names another file
    videos/<camera>.mp4      one video per camera (any suffix of mmocap.video.VIDEO_SUFFIXES),
      or images/<camera>/    one image file per frame (.png, .jpg, ...), in name order
    background/<camera>.mp4  optional: the empty scene (a plate), as a video or an image
      or background/<camera>/  folder; or dataset.background names frames of the main videos
                             where nobody is in view; without either, the foreground comes
                             from person segmentation (mmocap.stages.foreground)
    masks/<camera>.mp4       optional: the person's masks made by another tool (SAM, rembg,
      or masks/<camera>/     a matting tool), a video or image folder of 8-bit masks (255 the
                             person), one per frame of the camera's video, at its size; used
                             as the foreground as they are
    pose/<camera>_json/      optional: 2-D keypoints of a detector (Pose2Sim, OpenPose,
      or keypoints.csv       RTMPose...), OpenPose JSON per frame of the camera's video, or one
                             table (mmocap.data.keypoints); in the pixels of the frames as
                             stored, like the videos read with dataset.scale and offsets
    markers_mm.csv           optional ground truth: frame, marker, x_mm, y_mm, z_mm (frames
                             numbered from the synchronised frame 0, as the tracker's)

Image size: a video up to :data:`CODEC_PADDING_PX` pixels narrower or lower than its
calibration says is the calibrated image without the rows or columns a codec pads to a
multiple of 16 (a 1088-row sensor in a 1080-row video): it is read, with a one-line warning,
as the calibrated camera cropped at the right and bottom (the principal point kept). Any other
mismatch is an error.

Synchronisation: ``offsets`` gives, per camera, how many frames of its video come before the
common frame 0 (a camera started 3 frames early has offset 3). Frame ``k`` of the recording
is frame ``k + offset`` of each camera's source. World axes: the calibration's world,
turned so that ``up`` (the axis pointing up, e.g. ``+z`` for Pose2Sim) becomes mmocap's
``+y``; ground truth is turned with it. Translations become mm (``units``: mm, m, or auto:
detected and announced, never guessed silently).

A recording gives no first pose and names no subject: the automatic start
(:mod:`mmocap.stages.initialisation`) finds the pose and the body's height and girth.

:func:`write_recording` writes any sequence folder in this layout (OpenCV YAML calibration,
H.264 MP4 videos, ground truth), optionally with offsets and a turned world, so that the
path from a user's files to a tracked result is tested end to end on data with known truth.
"""

from __future__ import annotations

import itertools
import logging
import math
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from mmocap.body.model import MARKER_NAMES
from mmocap.camera import Camera
from mmocap.data.calibration import UP_AXIS_OF_FORMAT, calibration_suffix, read_calibration, write_opencv_yaml
from mmocap.data.keypoints import AUTO, KeypointFiles
from mmocap.data.sequence import Sequence, SequenceBase, listed, read_markers, write_markers
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.validate import check_choice, check_number
from mmocap.video import VIDEO_SUFFIXES, VideoReader, count_frames, frame_rate, write_video

log = logging.getLogger(__name__)

#: suffixes read as image files in an image folder
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: the names tried, in this order, for the calibration when ``dataset.calibration`` is null
CALIBRATION_NAMES = ("calibration",)
#: ``up``: the world axis pointing up -> the rotation taking the calibration's world to
#: mmocap's (y up), a right-handed turn
UP_AXES = {
    "+y": np.eye(3),
    "-y": np.diag([1.0, -1.0, -1.0]),
    "+z": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]),
    "-z": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
    "+x": np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]]),
    "-x": np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]]),
}
#: frame rates of the cameras' videos that differ by more than this fraction disagree
FPS_TOLERANCE = 0.01
#: the most rows or columns a codec adds to reach a multiple of 16 (see the module docstring)
CODEC_PADDING_PX = 16


class FrameSource:
    """The frames of one camera: a video file or a folder of image files.

    ``read(k)`` returns frame ``k`` (0-based) as the camera's images are (see
    :func:`mmocap.data.sequence.read_image`): (H, W, 3) BGR for a colour camera, (H, W) for
    a greyscale one, whose video frames are converted; the size must be the calibration's
    (``camera``'s), and the frame is then shrunk by ``scale`` (area averaging) to the size of
    ``camera.shrunk(scale)``.
    """

    def __init__(self, path: Path, camera: Camera, scale: float = 1.0):
        self.path, self.camera, self.scale = path, camera, scale
        if path.is_dir():
            self.files = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
            if not self.files:
                raise DataError(f"camera {camera.name}: no image files ({', '.join(IMAGE_SUFFIXES)}) in {path}")
            self.video = None
            self.count = len(self.files)
            self.fps = None
        else:
            self.files = None  # type: ignore[assignment]  # read() uses files only without a video
            self.video = VideoReader(path)
            self.count = count_frames(path)
            self.fps = frame_rate(path)
            if self.count == 0:
                raise DataError(f"camera {camera.name}: video {path} holds no frame that decodes")

    def frame_size(self) -> tuple[int, int]:
        """(width, height) in pixels of the source's first frame, as stored."""
        if self.video is None:
            image = cv2.imread(str(self.files[0]), cv2.IMREAD_UNCHANGED)
            if image is None:
                raise DataError(
                    f"camera {self.camera.name}: cannot read image {self.files[0]} (damaged, or not an image file)"
                )
        else:
            image = self.video.read(0)
        return image.shape[1], image.shape[0]

    @property
    def kind(self) -> str:
        """``"video"`` or ``"images"`` (a folder of image files)."""
        return "images" if self.video is None else "video"

    def read(self, index: int) -> np.ndarray:
        """Frame ``index`` (0-based) of the camera, as the class's docstring says."""
        return self.prepared(self.decoded(index), index)

    def decoded(self, index: int) -> np.ndarray:
        """Frame ``index`` (0-based) as stored: a video's (H, W, 3) BGR, or an image file read
        in colour or greyscale as the camera is."""
        if self.video is not None:
            return self.video.read(index)
        path = self.files[index]
        image = cv2.imread(str(path), cv2.IMREAD_COLOR if self.camera.colour else cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise DataError(f"camera {self.camera.name}: cannot read image {path} (damaged, or not an image file)")
        return image

    def prepared(self, image: np.ndarray, index: int) -> np.ndarray:
        """The :meth:`decoded` frame ``index`` converted to greyscale for a greyscale camera,
        its size checked against the calibration's, and shrunk by ``scale``."""
        cam = self.camera
        if self.video is not None and not cam.colour:
            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        if image.shape[:2] != (cam.height, cam.width):
            where = f"image {self.files[index]}" if self.video is None else f"frame {index} of video {self.path}"
            raise DataError(
                f"camera {cam.name}: {where} is {image.shape[1]}x{image.shape[0]}, its calibration "
                f"says {cam.width}x{cam.height}: the calibration of another resolution?"
            )
        if self.scale != 1:
            small = cam.shrunk(self.scale)
            image = cv2.resize(image, (small.width, small.height), interpolation=cv2.INTER_AREA)
        return image


def find_source(folder: Path, camera: str, what: str) -> Path | None:
    """``folder/<camera>`` as an image folder or ``folder/<camera>.<video suffix>``; None if
    neither exists, a DataError if both do (which one is meant?)."""
    found = [p for p in [folder / camera, *(folder / f"{camera}{s}" for s in VIDEO_SUFFIXES)] if p.exists()]
    if len(found) > 1:
        raise DataError(f"camera {camera}: {what} found twice ({', '.join(map(str, found))}); keep one")
    return found[0] if found else None


def fitted_to_frames(camera: Camera, source: FrameSource) -> Camera:
    """``camera`` with the image size of ``source``'s frames when they are the calibrated
    image less a codec's padding (module docstring; a warning says so), else ``camera`` itself
    (a size that differs otherwise is refused when a frame is read)."""
    width, height = source.frame_size()
    short_x, short_y = camera.width - width, camera.height - height
    if (short_x, short_y) == (0, 0) or not (0 <= short_x <= CODEC_PADDING_PX and 0 <= short_y <= CODEC_PADDING_PX):
        return camera
    warnings.warn(
        f"camera {camera.name}: {source.path} is {width}x{height}, its calibration says "
        f"{camera.width}x{camera.height}: read as the calibrated image without the codec's padding "
        "(cropped at the right and bottom, principal point kept)",
        MmocapWarning,
        stacklevel=2,
    )
    return replace(camera, width=width, height=height, _maps={})


def turned(camera: Camera, world: np.ndarray) -> Camera:
    """``camera`` in a world turned by ``world`` (3, 3): X_new = world @ X_old."""
    if np.array_equal(world, np.eye(3)):
        return camera
    return replace(camera, R=camera.R @ world.T, _maps={})


@dataclass
class RecordingSequence(SequenceBase):
    """An opened recording (see the module docstring): ``sources`` one FrameSource per
    camera, ``offsets`` per camera the source frame of the synchronised frame 0 (frame ``k``
    read is source frame ``meta["start"] + k + offset``), the background's sources and frame
    indices per camera, ``markers_path`` the ground truth or None, ``world`` the (3, 3) turn
    applied to the calibration's world, ``calibrated`` the names of every camera of the
    calibration."""

    # None only as dataclass defaults after SequenceBase's: open() gives every one
    sources: list = None  # type: ignore[assignment]
    offsets: list = None  # type: ignore[assignment]
    background_sources: list | None = None
    background_frames: list | None = None
    mask_sources: list | None = None
    markers_path: Path | None = None
    world: np.ndarray = None  # type: ignore[assignment]
    calibrated: list[str] | None = None

    @property
    def subject(self):
        return None  # nobody known: the automatic start fits the body

    def images(self, frame: int) -> list[np.ndarray]:
        self.check_frame(frame)
        first = int(self.meta["start"])
        return [source.read(first + frame + offset) for source, offset in zip(self.sources, self.offsets)]

    def background(self, camera: Camera) -> list[np.ndarray]:
        if self.background_sources is None:
            raise DataError(
                f"camera {camera.name}: no background video or image folder "
                f"{self.root / 'background' / camera.name}[.mp4]; record the empty scene, or "
                "set dataset.background=[first,last] to frames in which nobody is in view"
            )
        k = [c.name for c in self.cameras].index(camera.name)
        source, frames = self.background_sources[k], self.background_frames[k]  # type: ignore[index]  # with the sources
        return [source.read(f) for f in frames]

    @property
    def has_background(self) -> bool:
        return self.background_sources is not None

    @property
    def has_given_masks(self) -> bool:
        return self.mask_sources is not None

    def given_masks(self, frame: int) -> list[np.ndarray]:
        if self.mask_sources is None:
            return super().given_masks(frame)
        self.check_frame(frame)
        first = int(self.meta["start"])
        return [source.read(first + frame + offset) for source, offset in zip(self.mask_sources, self.offsets)]

    @property
    def has_keypoints(self) -> bool:
        return KeypointFiles.has(self.root)

    def keypoint_files(self, skeleton: str = AUTO) -> KeypointFiles:
        """The recording's keypoints (:class:`mmocap.data.keypoints.KeypointFiles`): frame ``k``
        is frame ``meta["start"] + k + offset`` of each camera's files, as of its video, and the
        pixels are those of the cameras as tracked (shrunk by ``dataset.scale``; a codec's
        padding, cropped at the right and bottom, moves no pixel)."""
        if not self.has_keypoints:
            return super().keypoint_files(skeleton)
        first = int(self.meta["start"])
        shrunk = [(source.camera, small) for small, source in zip(self.cameras, self.sources)]
        return KeypointFiles(
            self.root,
            [c.name for c in self.cameras],
            self.n_frames,
            skeleton,
            first_frames=[first + offset for offset in self.offsets],
            calibrated=self.calibrated,
            shrunk=shrunk,
        )

    @property
    def markers_source(self) -> str:
        return str(self.markers_path) if self.markers_path is not None else f"{self.root} (no markers_mm.csv)"

    def markers(self) -> np.ndarray:
        """(frames, 15, 3) mm: the ground truth of ``markers_mm.csv`` (turned into mmocap's
        world), NaN without the file."""
        names = list(self.meta["marker_names"])
        if self.markers_path is None:
            return np.full((self.n_frames, len(names), 3), np.nan)
        start = int(self.meta["start"])
        markers = read_markers(self.markers_path, int(self.meta["recorded_frames"]), names)
        return markers[start : start + self.n_frames] @ self.world.T

    def ground_truth(self, frames: int, missing_markers: str = "warn") -> np.ndarray:
        if self.markers_path is None:
            log.info("recording %s has no markers_mm.csv: the run has no marker error", self.root)
            return self.markers()[:frames]
        return super().ground_truth(frames, missing_markers)


class RecordingDataset:
    """Hydra component (``dataset=recording``): a recording folder (module docstring).

    Args:
        root: the recording folder.
        subject: the body preset the tracker starts from; its height and girth are fitted
            by the automatic start unless ``body.height_mm`` / ``body.girth`` are given.
        cameras: cameras to track with (None: every camera with frames).
        calibration: the calibration file or folder, relative to ``root`` (None: the one
            ``calibration.*`` or ``calibration/`` there).
        units: the calibration's translation units: ``mm``, ``m`` or ``auto``.
        up: the calibration world's axis that points up (``+y``, ``+z``, ...), or ``auto``:
            ``+z`` for QTM and Vicon calibrations (their labs' convention), else ``+y``.
        offsets: camera name -> frames of its source before the common frame 0.
        start: the first synchronised frame tracked.
        frames: frames to read at most (None: to the end of the shortest source).
        fps: frame rate (None: the videos'; required for image folders).
        background: None for the ``background/`` folder, or [first, last] synchronised
            frames of the main sources in which nobody is in view.
        background_frames: frames taken, evenly spaced, from the background.
        greyscale: cameras whose frames are used as greyscale.
        scale: tracks at this fraction of the cameras' resolution, in (0, 1]: every frame (and
            plate and given mask) is shrunk as it is read, the cameras' intrinsics with it
            (:meth:`mmocap.camera.Camera.shrunk`); the tracked poses, in mm, are unchanged.
    """

    def __init__(
        self,
        root: str,
        subject: str = "S1",
        cameras: list[str] | None = None,
        calibration: str | None = None,
        units: str = "auto",
        up: str = "auto",
        offsets: dict | None = None,
        start: int = 0,
        frames: int | None = None,
        fps: float | None = None,
        background: list[int] | None = None,
        background_frames: int = 20,
        greyscale: list[str] | None = None,
        scale: float = 1.0,
    ):
        self.path = Path(root)
        self.subject = subject
        self.cameras = None if cameras is None else list(cameras)
        self.calibration = calibration
        self.units = check_choice("dataset.units", units, ("mm", "m", "auto"))
        self.up = check_choice("dataset.up", up, ("auto", *UP_AXES))
        self.offsets = {
            str(k): check_number(f"dataset.offsets.{k}", v, 0, integer=True) for k, v in dict(offsets or {}).items()
        }
        self.start = check_number("dataset.start", start, 0, integer=True)
        self.frames = None if frames is None else check_number("dataset.frames", frames, 1, integer=True)
        self.fps = None if fps is None else check_number("dataset.fps", fps, 0, 10_000, low_open=True)
        if background is not None:
            if len(background) != 2:
                raise ConfigError(
                    f"dataset.background must be [first, last] frames of the empty scene, got {list(background)}"
                )
            first, last = (check_number("dataset.background", v, 0, integer=True) for v in background)
            if last < first:
                raise ConfigError(f"dataset.background: last frame {last} comes before first {first}")
            background = [first, last]
        self.background = background
        self.background_frames = check_number("dataset.background_frames", background_frames, 1, integer=True)
        self.greyscale = list(greyscale or [])
        self.scale = check_number("dataset.scale", scale, 0, 1, low_open=True)

    def calibration_path(self) -> Path:
        """The calibration file or folder (see ``calibration``)."""
        if self.calibration is not None:
            path = self.path / self.calibration
            if not path.exists():
                raise DataError(f"calibration {path} not found (dataset.calibration={self.calibration})")
            return path
        found = [
            p
            for name in CALIBRATION_NAMES
            for p in self.path.glob(f"{name}*")
            if p.is_dir() or calibration_suffix(p) is not None
        ]
        if not found:
            raise DataError(
                f"no calibration in recording {self.path}: add calibration.yml (OpenCV), "
                "calibration.toml (anipose / Pose2Sim) or a calibration/ folder, or name the file "
                "with dataset.calibration"
            )
        if len(found) > 1:
            raise DataError(
                f"recording {self.path} holds {len(found)} calibrations ({listed(found)}): "
                "name one with dataset.calibration"
            )
        return found[0]

    def open(self, progress: bool = True) -> RecordingSequence:
        """The recording opened for tracking: its calibration, cameras' frames and markers, each
        checked; a DataError naming the file and the fix otherwise."""
        root = self.path
        if not root.is_dir():
            raise DataError(f"recording folder not found: {root}")
        calibration = read_calibration(self.calibration_path(), self.units, units_key="dataset.units")
        up = self._up(calibration)
        world = UP_AXES[up]
        by_name = {c.name: turned(c, world) for c in calibration.cameras}
        for name in self.greyscale:
            if name not in by_name:
                raise ConfigError(
                    f"dataset.greyscale names camera {name}, which {calibration.source} lacks "
                    f"(it has {', '.join(by_name)})"
                )
            by_name[name] = replace(by_name[name], colour=False, _maps={})
        unknown = [name for name in self.offsets if name not in by_name]
        if unknown:
            raise ConfigError(
                f"dataset.offsets names camera {unknown[0]}, which {calibration.source} lacks "
                f"(it has {', '.join(by_name)})"
            )
        names = self.cameras or [n for n in by_name if self._main_source(n) is not None]
        missing = [n for n in names if n not in by_name]
        if missing:
            raise DataError(
                f"camera {missing[0]} not in calibration {calibration.source} (it has {', '.join(by_name)})"
            )
        if not names:
            raise DataError(
                f"recording {root}: no camera of {calibration.source} has a video in {root / 'videos'} "
                f"or an image folder in {root / 'images'}"
            )
        cameras, sources = [], []
        for name in names:
            path = self._main_source(name)
            if path is None:
                raise DataError(
                    f"camera {name}: no video {root / 'videos' / name}.mp4 (or another video suffix) "
                    f"and no image folder {root / 'images' / name}"
                )
            source = FrameSource(path, by_name[name], self.scale)
            source.camera = fitted_to_frames(source.camera, source)
            cameras.append(source.camera.shrunk(self.scale) if self.scale != 1 else source.camera)
            sources.append(source)
        offsets = [self.offsets.get(c.name, 0) for c in cameras]
        usable = [s.count - o for s, o in zip(sources, offsets)]
        if min(usable) <= self.start:
            k = int(np.argmin(usable))
            raise DataError(
                f"camera {cameras[k].name}: {sources[k].path} has {sources[k].count} frames; with offset "
                f"{offsets[k]} and dataset.start={self.start} none is left to track"
            )
        recorded = min(usable)
        n_frames = recorded - self.start if self.frames is None else min(self.frames, recorded - self.start)
        background_sources, background_frames = self._background(cameras, sources, offsets)
        mask_sources = self._masks(cameras, sources)
        markers = root / "markers_mm.csv"
        meta = {
            "format": "mmocap-recording/1",
            "subject": None,
            "action": root.resolve().name,
            "fps": self._fps(cameras, sources),
            "frames": n_frames,
            "recorded_frames": recorded,
            "start": self.start,
            "cameras": [c.name for c in cameras],
            "marker_names": list(MARKER_NAMES),
            "x0": None,
            "calibration": str(calibration.source),
            "units": calibration.units,
            "up": up,
        }
        return RecordingSequence(
            root,
            meta,
            cameras,
            sources=sources,
            offsets=offsets,
            background_sources=background_sources,
            background_frames=background_frames,
            mask_sources=mask_sources,
            markers_path=markers if markers.is_file() else None,
            world=world,
            calibrated=list(by_name),
        )

    def _up(self, calibration) -> str:
        """The calibration world's up axis: ``up``, or with ``auto`` the format's convention
        (:data:`mmocap.data.calibration.UP_AXIS_OF_FORMAT`, logged), else ``+y``."""
        if self.up != "auto":
            return self.up
        up = UP_AXIS_OF_FORMAT.get(calibration.format)
        if up is None:
            return "+y"
        log.info("dataset.up=auto: %s, the convention of %s (%s)", up, calibration.format, calibration.source)
        return up

    def _main_source(self, name: str) -> Path | None:
        videos = find_source(self.path / "videos", name, "a video")
        images = find_source(self.path / "images", name, "an image folder")
        if videos is not None and images is not None:
            raise DataError(f"camera {name}: both {videos} and {images} exist; keep one")
        return videos or images

    def _fps(self, cameras, sources) -> float:
        stated = {c.name: s.fps for c, s in zip(cameras, sources) if s.fps is not None}
        if self.fps is not None:
            return float(self.fps)
        if not stated:
            raise ConfigError("the recording's frame rate is unknown (image folders state none): set dataset.fps")
        low, high = min(stated.values()), max(stated.values())
        if high - low > FPS_TOLERANCE * high:
            rates = ", ".join(f"{name}: {fps:g}" for name, fps in stated.items())
            raise DataError(
                f"the cameras' videos disagree on the frame rate ({rates}): cameras at different rates "
                "cannot be synchronised frame by frame; resample them, or set dataset.fps if the "
                "containers are wrong"
            )
        return float(np.median(list(stated.values())))

    def _masks(self, cameras, sources) -> list[FrameSource] | None:
        """Per camera, the source of its given masks (``masks/<camera>``), each with as many
        frames as the camera's video and at its size; None if the recording has no masks/."""
        folder = self.path / "masks"
        found = {camera.name: find_source(folder, camera.name, "masks") for camera in cameras}
        if not any(found.values()):
            return None
        missing = [name for name, path in found.items() if path is None]
        if missing:
            raise DataError(
                f"camera {missing[0]}: {folder} holds masks of other cameras but none of this one; add "
                f"{folder / missing[0]}/ (one mask image per frame) or {folder / missing[0]}.mp4, or leave it "
                "out with dataset.cameras"
            )
        masks = []
        for source in sources:
            camera = source.camera  # the frames' own size
            mask = FrameSource(found[camera.name], replace(camera, colour=False, _maps={}), self.scale)  # type: ignore[arg-type]  # all found
            if mask.count != source.count:
                raise DataError(
                    f"camera {camera.name}: {mask.path} holds {mask.count} masks, but {source.path} has "
                    f"{source.count} frames: give one mask per frame"
                )
            if mask.frame_size() != (camera.width, camera.height):
                width, height = mask.frame_size()
                raise DataError(
                    f"camera {camera.name}: the masks in {mask.path} are {width}x{height}, but its frames are "
                    f"{camera.width}x{camera.height}: give masks at the frames' size"
                )
            masks.append(mask)
        return masks

    def _background(self, cameras, sources, offsets):
        """Per camera: the source of its empty-scene frames and the frame indices to take;
        (None, None) when the recording has no plate (no background/ folder and no
        ``background`` range)."""
        if self.background is None and not (self.path / "background").is_dir():
            return None, None
        out_sources, out_frames = [], []
        for camera, source, offset in zip(cameras, sources, offsets):
            if self.background is not None:
                first, last = self.background
                if last + offset >= source.count:
                    raise DataError(
                        f"camera {camera.name}: dataset.background ends at frame {last}, after the end "
                        f"of {source.path} ({source.count} frames, offset {offset})"
                    )
                frames = np.unique(np.linspace(first, last, self.background_frames).round().astype(int)) + offset
                out_sources.append(source)
            else:
                path = find_source(self.path / "background", camera.name, "a background")
                if path is None:
                    raise DataError(
                        f"camera {camera.name}: no background video or image folder "
                        f"{self.path / 'background' / camera.name}[.mp4]; record the empty scene, or "
                        "set dataset.background=[first,last] to frames in which nobody is in view"
                    )
                background = FrameSource(path, source.camera, self.scale)
                frames = np.unique(np.linspace(0, background.count - 1, self.background_frames).round().astype(int))
                out_sources.append(background)
            out_frames.append(frames.tolist())
        return out_sources, out_frames


def write_recording(
    sequence: Sequence,
    out: Path,
    offsets: dict | None = None,
    yaw_deg: float = 0.0,
    units: str = "mm",
    crf: int = 0,
    progress: bool = True,
) -> Path:
    """Write ``sequence`` (a sequence folder, opened) as a recording folder ``out``:
    ``calibration.yml`` (OpenCV YAML, translations in ``units``), ``videos/<camera>.mp4``,
    ``background/<camera>.mp4`` and ``markers_mm.csv``; no first pose and no subject.

    ``offsets`` (camera -> frames) puts that many frames of the empty scene before a
    camera's video, as a camera started early would; the recording is then read with the
    same ``dataset.offsets``. ``yaw_deg`` turns the world about its vertical axis, so that
    the same images show the person at another heading in the calibration's world. ``crf``
    is the videos' H.264 quality (:func:`mmocap.video.write_video`; 0, the default, is
    lossless: the recording then holds the sequence's own pixels). Returns ``out``.
    """
    offsets = {str(k): check_number(f"offsets.{k}", v, 0, 10_000, integer=True) for k, v in (offsets or {}).items()}
    names = [c.name for c in sequence.cameras]
    unknown = [name for name in offsets if name not in names]
    if unknown:
        raise ConfigError(
            f"offsets name camera {unknown[0]}, which sequence {sequence.root} lacks (it has {', '.join(names)})"
        )
    units = check_choice("units", units, ("mm", "m"))
    yaw = math.radians(check_number("yaw", yaw_deg, -360, 360))
    world = np.array([[math.cos(yaw), 0, math.sin(yaw)], [0, 1, 0], [-math.sin(yaw), 0, math.cos(yaw)]])
    out = Path(out)
    write_opencv_yaml(out / "calibration.yml", [turned(c, world) for c in sequence.cameras], units=units)
    for camera in sequence.cameras:
        one = Sequence(sequence.root, sequence.meta, [camera])
        empty = one.background(camera)
        early = [empty[k % len(empty)] for k in range(offsets.get(camera.name, 0))]
        frames = (one.images(k)[0] for k in range(sequence.n_frames))
        write_video(
            out / "videos" / f"{camera.name}.mp4",
            itertools.chain(early, frames),
            sequence.fps,
            count=len(early) + sequence.n_frames,
            progress=progress,
            crf=crf,
        )
        write_video(out / "background" / f"{camera.name}.mp4", iter(empty), sequence.fps, count=len(empty), crf=crf)
    write_markers(out / "markers_mm.csv", sequence.markers() @ world.T, sequence.meta["marker_names"])
    return out
