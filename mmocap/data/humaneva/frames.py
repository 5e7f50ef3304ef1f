"""HumanEva-I's images: one camera's video, or a folder of numbered image files, read by
1-based image index (:class:`FrameSource`)."""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np

from mmocap.data.humaneva.layout import is_colour
from mmocap.data.sequence import listed
from mmocap.errors import DataError
from mmocap.video import VideoReader

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm")


class FrameSource:
    """The images of one camera: a video decoded in order (:class:`mmocap.video.VideoReader`;
    reading backwards decodes from the start again), or a folder of numbered images
    (the k-th file in numerical order being image k, the numbers consecutive).  Indices
    are 1-based.

    Images come out as (H, W, 3) BGR for a colour camera and (H, W) for a greyscale one,
    all of the first image's size.  A greyscale camera's 3-channel frames are converted to
    greyscale, as HumanEva-I's own greyscale videos are stored in colour; a colour camera's
    file must have 3 channels, since colour cannot be recovered from a greyscale image.  A
    gap in the numbers, a file of another size, channel count or depth, or one OpenCV
    cannot read is a DataError naming the camera and the file.
    """

    def __init__(self, path: Path, camera: str, colour: bool):
        self.path, self.camera, self.colour = Path(path), camera, colour
        self._video = None
        self.width = self.height = None
        if self.path.is_dir():
            files = [p for p in self.path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES]
            self.files = sorted(files, key=_frame_number)
            if not self.files:
                raise DataError(f"camera {camera}: no image files in {self.path}")
            _check_numbering(self.files, camera)
            self.count = len(self.files)
        else:
            self.files = None  # type: ignore[assignment]  # a video: no files
            capture = cv2.VideoCapture(str(self.path))
            self.count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
            opened = capture.isOpened()
            capture.release()
            if not opened or self.count < 1:
                raise DataError(f"camera {camera}: cannot read video {self.path}")
            self._video = VideoReader(self.path)
        self.height, self.width = self.read(1).shape[:2]

    def read(self, index: int) -> np.ndarray:
        """Image ``index`` (1-based)."""
        if not 1 <= index <= self.count:
            raise DataError(f"camera {self.camera}: image {index} outside {self.path} ({self.count} images)")
        if self.files is not None:
            where = self.files[index - 1]
            image = cv2.imread(str(where), cv2.IMREAD_UNCHANGED)
        else:  # decoded in order: a seek in an XviD file with B-frames can return another frame
            try:
                image = self._video.read(index - 1)
            except DataError as exc:
                raise DataError(f"camera {self.camera}: {exc}") from None
            where = f"{self.path} (image {index})"
        if image is None:
            raise DataError(f"camera {self.camera}: cannot read {where} (damaged, or not an image)")
        channels = 1 if image.ndim == 2 else image.shape[2]
        if image.dtype != np.uint8 or channels not in (1, 3):
            raise DataError(
                f"camera {self.camera}: {where} has {channels} channels of {image.dtype}; "
                "mmocap reads 8-bit greyscale or BGR images"
            )
        if self.colour and channels == 1:
            raise DataError(
                f"camera {self.camera}: {where} is greyscale, but {self.camera} is a colour "
                "camera: its images must have 3 channels"
            )
        if self.width is not None and image.shape[:2] != (self.height, self.width):
            raise DataError(
                f"camera {self.camera}: {where} is {image.shape[1]}x{image.shape[0]}, its first "
                f"image {self.width}x{self.height}"
            )
        return image if self.colour or channels == 1 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)


def _check_numbering(files: list[Path], camera: str) -> None:
    """Image files sorted by :func:`_frame_number` must be numbered consecutively: a gap
    would shift every later image to another time."""
    numbers = [_frame_number(p)[0] for p in files]
    unnumbered = [p.name for p, n in zip(files, numbers) if n < 0]
    if unnumbered:
        raise DataError(
            f"camera {camera}: {files[0].parent} holds image files without a frame number: {listed(unnumbered)}"
        )
    expected = range(numbers[0], numbers[0] + len(numbers))
    if numbers != list(expected):
        gaps = sorted(set(range(numbers[0], numbers[-1] + 1)) - set(numbers))
        repeats = sorted({n for n in numbers if numbers.count(n) > 1})
        raise DataError(
            f"camera {camera}: the images in {files[0].parent} are not numbered consecutively "
            f"(missing: {listed(gaps) or 'none'}, repeated: {listed(repeats) or 'none'}); each image "
            "must be there once, as the k-th file is taken for image k"
        )


def _frame_number(path: Path) -> tuple[int, str]:
    digits = re.findall(r"\d+", path.stem)
    return (int(digits[-1]) if digits else -1, path.name)


def open_frames(folder: Path, stem: str, camera: str) -> FrameSource:
    """``<folder>/<stem>.avi`` or, failing that, the image folder ``<folder>/<stem>``."""
    video, images = folder / f"{stem}.avi", folder / stem
    if video.is_file():
        return FrameSource(video, camera, is_colour(camera))
    if images.is_dir():
        return FrameSource(images, camera, is_colour(camera))
    raise DataError(f"camera {camera}: image data not found: {video} (nor a folder {images})")
