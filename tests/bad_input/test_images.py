"""Bad images: each stops the run with one line naming the camera and the file.

An image must be what its camera's calibration describes: 8 bits, 3 channels (BGR) for a
colour camera and 1 for a greyscale one, of the calibration's size. Nothing is converted
(:func:`mmocap.data.sequence.read_image`). Before, a greyscale file in a colour camera was
silently read as colour (``cv2.IMREAD_COLOR`` copies the grey into three channels) and tracked.
"""

import cv2
import numpy as np
import pytest

from tests.helpers import assert_clean_error, track_args
from tests.helpers import mmocap_in_process as mmocap


def rewrite(path, convert) -> None:
    """The image at ``path`` replaced by ``convert(image)``."""
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert cv2.imwrite(str(path), convert(image))


CASES = {
    "greyscale-in-colour-camera": (
        "C1",
        lambda p: rewrite(p, lambda im: cv2.cvtColor(im, cv2.COLOR_BGR2GRAY)),
        ("has 1 channel", "is colour"),
    ),
    "colour-in-greyscale-camera": (
        "BW1",
        lambda p: rewrite(p, lambda im: cv2.cvtColor(im, cv2.COLOR_GRAY2BGR)),
        ("has 3 channels", "is greyscale"),
    ),
    "with-alpha-channel": (
        "C1",
        lambda p: rewrite(p, lambda im: cv2.cvtColor(im, cv2.COLOR_BGR2BGRA)),
        ("has 4 channels",),
    ),
    "16-bit": ("BW1", lambda p: rewrite(p, lambda im: im.astype(np.uint16) * 256), ("uint16", "8-bit")),
    "wrong-size": ("C1", lambda p: rewrite(p, lambda im: cv2.resize(im, (80, 60))), ("is 80x60", "160x120")),
    "corrupt": ("BW1", lambda p: p.write_bytes(b"\x89PNG\r\n\x1a\n" + b"garbage" * 50), ("cannot read",)),
    "truncated": ("C1", lambda p: p.write_bytes(p.read_bytes()[:300]), ("cannot read",)),
}


@pytest.mark.parametrize(("camera", "damage", "culprits"), CASES.values(), ids=CASES.keys())
def test_a_bad_image_names_camera_and_file(sequence_copy, tmp_path, camera, damage, culprits):
    path = sequence_copy / "images" / camera / "000001.png"
    damage(path)
    out = tmp_path / "run"
    assert_clean_error(mmocap(*track_args(sequence_copy, out)), f"camera {camera}", str(path), *culprits)
    assert not (out / "summary.json").exists()


def test_the_old_reader_took_a_greyscale_file_for_colour(sequence_copy):
    """The silent case above: ``IMREAD_COLOR`` hands back three equal channels, which is
    why the file's own channel count is read now."""
    path = sequence_copy / "images" / "C1" / "000000.png"
    rewrite(path, lambda im: cv2.cvtColor(im, cv2.COLOR_BGR2GRAY))
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert image.shape[2] == 3
    assert np.array_equal(image[..., 0], image[..., 2])


def test_a_greyscale_background_frame_in_a_colour_camera_names_it(sequence_copy, tmp_path):
    path = sorted((sequence_copy / "background" / "C1").glob("*.png"))[0]
    rewrite(path, lambda im: cv2.cvtColor(im, cv2.COLOR_BGR2GRAY))
    assert_clean_error(mmocap(*track_args(sequence_copy, tmp_path / "run")), "camera C1", str(path), "1 channel")


def test_a_missing_frame_is_found_when_the_sequence_opens(sequence_copy, tmp_path):
    (sequence_copy / "images" / "BW1" / "000001.png").unlink()
    assert_clean_error(
        mmocap(*track_args(sequence_copy, tmp_path / "run")),
        "camera BW1",
        str(sequence_copy / "images" / "BW1"),
        "000001.png",
        "lacks 1 of the 2 frames",
    )
