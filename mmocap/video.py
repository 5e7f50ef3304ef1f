"""Video files: frames read in decoding order, and MP4 and lossless AVI files written atomically.

Reading uses OpenCV's FFmpeg build (in ``opencv-python-headless``). Frames are decoded one
after another and never sought: seeking in videos with B-frames (XviD, H.264) can return a
neighbouring frame, so :class:`VideoReader` reopens the file and decodes forward when asked
for an earlier frame. A video's frame count is the number of frames that decode
(:func:`count_frames`), not the container's claim (``CAP_PROP_FRAME_COUNT``), which may be
an estimate.

Writing (:func:`write_video`) uses ``imageio-ffmpeg`` (the ``video`` extra: ``pip install
'mmocap[video]'``), which ships its own ffmpeg binary and writes H.264 MP4 files that
browsers, players and Blender open; without it, OpenCV's MPEG-4 Part 2 (``mp4v``) encoder,
which is lossy whatever the quality asked (a lossless video is then refused). A path
ending in ``.avi`` is written losslessly in FFV1 by OpenCV (HumanEva-I's container; FFV1
needs no extra). Either way the file is written beside its target and renamed when complete
(:func:`mmocap.io.atomic_path`), and then decoded again to check its frame count.
"""

from __future__ import annotations

import importlib.util
import itertools
from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np
from tqdm.auto import tqdm

from mmocap.errors import DataError
from mmocap.io import atomic_path, incomplete_write
from mmocap.validate import check_number

#: suffixes read as video files
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".webm", ".mpg", ".mpeg")
#: H.264 quality of written videos (constant rate factor: 0 lossless, 23 ffmpeg's default)
H264_CRF = 16
#: the constant rate factors libx264 takes
CRF_RANGE = (0, 51)
#: the suffix of videos written losslessly in FFV1 (as ``crf=0``) rather than as MP4
LOSSLESS_AVI_SUFFIX = ".avi"


def _open(path: Path) -> cv2.VideoCapture:
    if not path.is_file():
        raise DataError(f"video not found: {path}")
    capture = cv2.VideoCapture(str(path))
    if not capture.isOpened():
        raise DataError(
            f"cannot open video {path} (damaged, or a codec OpenCV's FFmpeg cannot decode); "
            "convert it to H.264 MP4, e.g. ffmpeg -i IN -c:v libx264 OUT.mp4"
        )
    return capture


def count_frames(path: str | Path) -> int:
    """Frames of the video at ``path`` that decode (DataError if it cannot be opened)."""
    capture = _open(Path(path))
    count = 0
    try:
        while capture.grab():
            count += 1
    finally:
        capture.release()
    return count


def frame_rate(path: str | Path) -> float | None:
    """The frame rate the container of ``path`` states (frames/s), None if it states none."""
    capture = _open(Path(path))
    try:
        fps = float(capture.get(cv2.CAP_PROP_FPS))
    finally:
        capture.release()
    return fps if np.isfinite(fps) and fps > 0 else None


class VideoReader:
    """Frames of one video by index, decoded in order (see the module docstring).

    ``reader.read(k)`` returns frame ``k`` (0-based) as (H, W, 3) uint8 BGR; reading frames
    in increasing order decodes each frame once.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._capture: cv2.VideoCapture | None = None
        self._next = 0  # index of the frame the next decode returns

    def read(self, index: int) -> np.ndarray:
        """Frame ``index`` (0-based) as (H, W, 3) uint8 BGR; a DataError naming the video if it
        ends before."""
        if self._capture is None or index < self._next:
            self.close()
            self._capture, self._next = _open(self.path), 0
        while self._next < index:
            if not self._capture.grab():
                break
            self._next += 1
        ok, frame = self._capture.read() if self._next == index else (False, None)
        if not ok:
            raise DataError(f"video {self.path} ends before frame {index} (0-based): it has {self._next} frames")
        self._next += 1
        return frame  # type: ignore[return-value]  # ok: a frame

    def close(self) -> None:
        """Release the decoder; a later :meth:`read` opens the video again."""
        if self._capture is not None:
            self._capture.release()
            self._capture = None

    def __del__(self):
        self.close()


def write_video(
    path: str | Path,
    frames: Iterable[np.ndarray],
    fps: float,
    count: int | None = None,
    progress: bool = False,
    crf: int = H264_CRF,
) -> Path:
    """Write ``frames`` ((H, W, 3) BGR or (H, W) grey uint8, all of one size) as an MP4 video
    at ``fps`` frames/s, atomically; returns the path. ``count`` (the number of frames, if
    known) sizes the progress bar. ``crf`` is the H.264 quality (0: lossless, coded in RGB,
    which browsers do not play but FFmpeg-based readers do). A path ending in ``.avi`` is an
    FFV1 video, lossless, and takes ``crf=0`` only. The written file is decoded again: a
    video that does not hold every frame is a WriteError (a full disk)."""
    path = Path(path)
    crf = check_number("crf", crf, *CRF_RANGE, integer=True)
    avi = path.suffix.lower() == LOSSLESS_AVI_SUFFIX
    if avi and crf != 0:
        raise DataError(
            f"cannot write {path} with crf={crf}: an .avi video is written losslessly (FFV1); "
            "give crf=0, or an .mp4 path for a compressed video"
        )
    frames = iter(frames)
    first = next(frames, None)
    if first is None:
        raise DataError(f"no frames to write into {path}")
    height, width = first.shape[:2]
    written = 0
    bar = tqdm(total=count, desc=f"write {path.name}", unit="frame", disable=not progress)
    with atomic_path(path) as target:
        # the encoders pick the container from the suffix
        encoded = target.with_suffix(LOSSLESS_AVI_SUFFIX if avi else ".mp4")
        try:
            with _Encoder(encoded, width, height, fps, crf) as write:
                for frame in itertools.chain([first], frames):
                    if frame.shape[:2] != (height, width):
                        raise DataError(
                            f"{path}: frame {written} is {frame.shape[1]}x{frame.shape[0]}, "
                            f"the first was {width}x{height}"
                        )
                    write(frame if frame.ndim == 3 else cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
                    written += 1
                    bar.update()
            decoded = count_frames(encoded)
            if decoded != written:
                raise incomplete_write(path, f"the video holds {decoded} of the {written} frames written")
            encoded.replace(target)  # atomic_path renames its own temporary to path
        finally:
            bar.close()
            encoded.unlink(missing_ok=True)
    return path


class _Encoder:
    """Context manager yielding ``write(bgr_frame)``: OpenCV's FFV1 for an ``.avi`` path, else
    imageio-ffmpeg's H.264 if installed, else OpenCV's mp4v."""

    def __init__(self, path: Path, width: int, height: int, fps: float, crf: int):
        self.path, self.size, self.fps, self.crf = path, (width, height), float(fps), int(crf)

    def __enter__(self):
        if self.path.suffix == LOSSLESS_AVI_SUFFIX:
            self._cv = cv2.VideoWriter(str(self.path), cv2.VideoWriter_fourcc(*"FFV1"), self.fps, self.size, True)
            if not self._cv.isOpened():
                raise DataError(f"cannot write video {self.path}")
            return self._cv.write
        if importlib.util.find_spec("imageio_ffmpeg") is None:
            if self.crf == 0:
                raise DataError(
                    f"cannot write the lossless video {self.path}: OpenCV's own MP4 encoder is lossy; "
                    "install the video extra (pip install 'mmocap[video]'), or ask for a compressed one"
                )
            self._cv = cv2.VideoWriter(str(self.path), cv2.VideoWriter_fourcc(*"mp4v"), self.fps, self.size)
            if not self._cv.isOpened():
                raise DataError(
                    f"OpenCV cannot write MP4 video {self.path}; install the video extra: pip install 'mmocap[video]'"
                )
            return self._cv.write
        import imageio_ffmpeg

        self._cv = None
        # H.264 in 4:2:0 chroma, which every player decodes, needs even sizes: an odd-sized
        # frame keeps its size in 4:4:4 instead of being resized; lossless is coded in RGB
        # (libx264rgb), as a conversion to YUV and back would round the pixels.
        even = self.size[0] % 2 == 0 and self.size[1] % 2 == 0
        codec, pix_fmt = ("libx264rgb", "bgr24") if self.crf == 0 else ("libx264", "yuv420p" if even else "yuv444p")
        self._ffmpeg = imageio_ffmpeg.write_frames(
            str(self.path),
            self.size,
            fps=self.fps,
            codec=codec,
            pix_fmt_in="bgr24",
            pix_fmt_out=pix_fmt,
            macro_block_size=1,
            output_params=["-crf", str(self.crf), "-preset", "fast"],
            ffmpeg_log_level="error",
        )
        self._ffmpeg.send(None)
        return lambda frame: self._ffmpeg.send(np.ascontiguousarray(frame))

    def __exit__(self, *exc):
        if self._cv is not None:
            self._cv.release()
        else:
            self._ffmpeg.close()
        return False
