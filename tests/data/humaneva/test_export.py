"""A synthetic sequence exported in the HumanEva-I layout: its names, and what reads back."""

import cv2
import numpy as np
import pytest

from mmocap.data.humaneva.export import export
from mmocap.data.sequence import Sequence
from mmocap.video import count_frames, frame_rate
from tests.helpers import HE_FRAMES, HE_LEAD_IN, open_he
from tests.helpers import mmocap as run_mmocap


def test_exported_layout_has_the_real_names(exported):
    for path in (
        "S1/Calibration_Data/C1.cal",
        "S1/Calibration_Data/BW1.cal",
        "S1/Image_Data/Walking_1_(C1).avi",
        "S1/Image_Data/Walking_1_(BW1).avi",
        "S1/Sync_Data/Walking_1_(C1).ofs",
        "S1/Mocap_Data/Walking_1.mat",
        "Background/Background_1_(C1).avi",
        "Background/Background_1_(BW1).avi",
    ):
        assert (exported / path).is_file(), path


@pytest.mark.parametrize(
    ("video", "frames"),
    [("S1/Image_Data/Walking_1_(C1).avi", HE_LEAD_IN + HE_FRAMES), ("Background/Background_1_(BW1).avi", 3)],
)
def test_exported_videos_are_ffv1_at_the_sequence_rate(synthetic, exported, video, frames):
    """Lossless FFV1 in AVI, as :func:`mmocap.video.write_video` writes an .avi path."""
    capture = cv2.VideoCapture(str(exported / video))
    codec = int(capture.get(cv2.CAP_PROP_FOURCC)).to_bytes(4, "little").decode().upper()
    capture.release()
    assert codec == "FFV1"
    assert count_frames(exported / video) == frames
    assert frame_rate(exported / video) == pytest.approx(Sequence.open(synthetic).fps)


@pytest.mark.parametrize("images", ["avi", "png"])
def test_images_background_and_markers_round_trip(synthetic, tmp_path, images):
    root = export(synthetic, tmp_path / "he", images=images, progress=False)
    seq = open_he(root)
    original = Sequence.open(synthetic)
    # the sequence after the lead-in copies, at the toolbox's first frame (image 6)
    assert seq.n_frames == HE_FRAMES
    assert seq.subject == "S1"
    assert seq.meta["first_image"] == 6
    for f in range(HE_FRAMES):
        for mine, theirs in zip(seq.images(f), original.images(f)):
            np.testing.assert_array_equal(mine, theirs)  # lossless video
    for cam, cam0 in zip(seq.cameras, original.cameras):
        np.testing.assert_array_equal(np.stack(seq.background(cam)), np.stack(original.background(cam0)))
    np.testing.assert_allclose(seq.markers(), original.markers(), atol=1e-9)


def test_export_command(synthetic, tmp_path):
    def mmocap(*args):
        return run_mmocap("export-humaneva", *args, cwd=tmp_path, timeout=120)

    out = mmocap(synthetic, tmp_path / "he", "--images", "png", "--trial", "3")
    assert out.returncode == 0, out.stderr
    assert len(list((tmp_path / "he/S1/Image_Data/Walking_3_(BW1)").glob("*.png"))) == HE_LEAD_IN + HE_FRAMES
    bad = mmocap(tmp_path / "nothing", tmp_path / "he2")
    assert bad.returncode == 2
    assert "not a sequence folder" in bad.stderr
    assert "Traceback" not in bad.stderr
