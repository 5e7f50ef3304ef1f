"""A camera's images from a video or a folder of image files: colour, numbering, damage."""

import cv2
import numpy as np
import pytest

from mmocap.data.humaneva.frames import FrameSource
from mmocap.errors import DataError


def image_folder(tmp_path, images, names=None):
    folder = tmp_path / "Walking_1_(C1)"
    folder.mkdir()
    for k, image in enumerate(images):
        cv2.imwrite(str(folder / (names[k] if names else f"{k + 1:06d}.png")), image)
    return folder


def test_image_folders_of_a_greyscale_camera_may_hold_colour_frames(tmp_path):
    """As HumanEva-I's greyscale videos are stored in colour, a greyscale camera's
    3-channel frames are converted; 1-channel frames are taken as they are."""
    grey = np.arange(12 * 16, dtype=np.uint8).reshape(12, 16)
    source = FrameSource(image_folder(tmp_path, [cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR), grey]), "BW1", False)
    np.testing.assert_array_equal(source.read(1), grey)
    np.testing.assert_array_equal(source.read(2), grey)


def test_a_greyscale_frame_in_a_colour_camera_is_refused(tmp_path):
    colour = np.zeros((12, 16, 3), np.uint8)
    source = FrameSource(image_folder(tmp_path, [colour, colour[..., 0]]), "C1", True)
    with pytest.raises(DataError, match=r"camera C1: .*000002.png is greyscale, but C1 is a colour camera"):
        source.read(2)


@pytest.mark.parametrize(
    ("images", "message"),
    [
        (
            [np.zeros((12, 16, 3), np.uint8), np.zeros((10, 16, 3), np.uint8)],
            r"000002.png is 16x10, its first image 16x12",
        ),
        ([np.zeros((12, 16, 4), np.uint8)], "has 4 channels of uint8"),
        ([np.zeros((12, 16, 3), np.uint16)], "has 3 channels of uint16"),
    ],
)
def test_bad_frames_in_an_image_folder_name_camera_and_file(tmp_path, images, message):
    folder = image_folder(tmp_path, images)
    with pytest.raises(DataError, match=f"camera C1: .*{message}"):
        FrameSource(folder, "C1", True).read(len(images))


@pytest.mark.parametrize(
    ("names", "message"),
    [
        (["000001.png", "000002.png", "000004.png"], r"not numbered consecutively \(missing: 3, repeated: none\)"),
        (["000001.png", "000001.jpg", "000002.png"], r"not numbered consecutively \(missing: none, repeated: 1\)"),
        (["000001.png", "first.png"], "without a frame number: first.png"),
    ],
)
def test_a_gap_in_the_image_numbers_is_refused(tmp_path, names, message):
    folder = image_folder(tmp_path, [np.zeros((12, 16, 3), np.uint8)] * len(names), names)
    with pytest.raises(DataError, match=f"camera C1: .*{message}"):
        FrameSource(folder, "C1", True)


def test_an_xvid_video_with_b_frames_gives_every_image_in_any_order(tmp_path):
    """HumanEva-I's videos are XviD (MPEG-4 part 2) with B-frames, in which a seek may
    land on another frame; the images come out as a decode from the start gives them,
    whatever the order they are asked in."""
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    base = np.random.default_rng(0).integers(0, 256, (48, 64, 3), dtype=np.uint8)
    frames = [np.ascontiguousarray(np.roll(base, 3 * k, axis=1)) for k in range(30)]
    path = tmp_path / "Walking_1_(C1).avi"
    writer = imageio_ffmpeg.write_frames(
        str(path),
        (64, 48),
        fps=60,
        codec="mpeg4",
        pix_fmt_in="bgr24",
        output_params=["-bf", "2", "-g", "12", "-vtag", "XVID", "-q:v", "3"],
        macro_block_size=1,
    )
    writer.send(None)
    for frame in frames:
        writer.send(frame)
    writer.close()
    capture, decoded = cv2.VideoCapture(str(path)), []
    while (image := capture.read()[1]) is not None:
        decoded.append(image)
    capture.release()
    assert len(decoded) == 30
    nearest = [int(np.argmin([np.abs(d.astype(int) - f).mean() for f in frames])) for d in decoded]
    assert nearest == list(range(30))  # the video holds every frame, in order
    source = FrameSource(path, "C1", True)
    for index in (6, 18, 4, 30, 12, 26, 9, 1, 30):
        np.testing.assert_array_equal(source.read(index), decoded[index - 1])


def test_a_damaged_frame_names_camera_and_file(tmp_path):
    folder = image_folder(tmp_path, [np.zeros((12, 16, 3), np.uint8)] * 2)
    (folder / "000002.png").write_bytes(b"\x89PNG\r\n\x1a\n damaged")
    with pytest.raises(DataError, match=r"camera C1: cannot read .*000002.png"):
        FrameSource(folder, "C1", True).read(2)
