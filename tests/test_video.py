"""mmocap.video: frames decoded in order, MP4 and lossless AVI files written whole or not at all."""

import cv2
import numpy as np
import pytest

from mmocap.errors import ConfigError, DataError
from mmocap.video import VideoReader, count_frames, frame_rate, write_video


def ramp(count: int, width: int = 64, height: int = 48) -> list[np.ndarray]:
    """Frames whose grey level tells their index (10 per frame), with a colour gradient."""
    frames = []
    for k in range(count):
        frame = np.full((height, width, 3), 10 * k, np.uint8)
        frame[..., 2] = np.linspace(0, 255, width, dtype=np.uint8)[None]
        frames.append(frame)
    return frames


@pytest.mark.parametrize("size", [(64, 48), (65, 47)], ids=["even", "odd"])
def test_a_lossless_video_reads_back_frame_for_frame_at_its_size(tmp_path, size):
    frames = ramp(12, *size)
    path = write_video(tmp_path / "v.mp4", frames, fps=25, crf=0)
    assert count_frames(path) == 12
    assert frame_rate(path) == pytest.approx(25)
    reader = VideoReader(path)
    for k in (0, 5, 6, 11, 2):  # forwards, then back: reopened and decoded forwards
        np.testing.assert_array_equal(reader.read(k), frames[k])
    assert list(tmp_path.iterdir()) == [path]


def test_a_compressed_video_keeps_every_frame_near_its_values(tmp_path):
    frames = ramp(8)
    path = write_video(tmp_path / "v.mp4", frames, fps=30)
    reader = VideoReader(path)
    for k in range(8):
        assert np.abs(reader.read(k).astype(int) - frames[k]).mean() < 3


def test_a_greyscale_frame_is_written_as_grey_colour(tmp_path):
    grey = [np.full((48, 64), 100 + k, np.uint8) for k in range(3)]
    frame = VideoReader(write_video(tmp_path / "g.mp4", grey, fps=30, crf=0)).read(1)
    assert frame.shape == (48, 64, 3)
    assert np.all(frame == 101)


def test_reading_past_the_end_names_the_video_and_its_length(tmp_path):
    path = write_video(tmp_path / "v.mp4", ramp(3), fps=30)
    with pytest.raises(DataError, match=r"v.mp4 ends before frame 3 .*it has 3 frames"):
        VideoReader(path).read(3)


def test_frames_of_two_sizes_are_refused_and_nothing_is_left(tmp_path):
    with pytest.raises(DataError, match=r"frame 1 is 32x48, the first was 64x48"):
        write_video(tmp_path / "v.mp4", [ramp(1)[0], ramp(1, 32)[0]], fps=30)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("bad", [-1, 52, 1.5])
def test_a_quality_out_of_range_is_refused(tmp_path, bad):
    with pytest.raises(ConfigError, match="crf"):
        write_video(tmp_path / "v.mp4", ramp(2), fps=30, crf=bad)


def test_a_file_that_is_not_a_video_is_one_clear_error(tmp_path):
    path = tmp_path / "broken.mp4"
    path.write_bytes(b"not a video")
    with pytest.raises(DataError, match="cannot open video .*broken.mp4"):
        count_frames(path)


def test_without_imageio_ffmpeg_opencv_writes_a_lossy_video_and_refuses_a_lossless_one(tmp_path, monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "imageio_ffmpeg" else real(name, *a)
    )
    path = write_video(tmp_path / "v.mp4", ramp(6), fps=30, crf=16)
    assert count_frames(path) == 6
    assert np.abs(VideoReader(path).read(3).astype(int) - ramp(6)[3]).mean() < 8
    with pytest.raises(DataError, match="lossless .*pip install 'mmocap\\[video\\]'"):
        write_video(tmp_path / "w.mp4", ramp(2), fps=30, crf=0)
    assert not (tmp_path / "w.mp4").exists()


def fourcc(path) -> str:
    capture = cv2.VideoCapture(str(path))
    code = int(capture.get(cv2.CAP_PROP_FOURCC))
    capture.release()
    return code.to_bytes(4, "little").decode().upper()


def test_an_avi_video_is_lossless_ffv1_and_takes_no_other_quality(tmp_path):
    frames = ramp(5)
    path = write_video(tmp_path / "v.avi", frames, fps=60, crf=0)
    assert fourcc(path) == "FFV1"
    assert count_frames(path) == 5
    assert frame_rate(path) == pytest.approx(60)
    reader = VideoReader(path)
    for k in range(5):
        np.testing.assert_array_equal(reader.read(k), frames[k])
    assert list(tmp_path.iterdir()) == [path]
    with pytest.raises(DataError, match=r"w.avi with crf=16: an .avi video is written losslessly \(FFV1\)"):
        write_video(tmp_path / "w.avi", frames, fps=60)
    assert list(tmp_path.iterdir()) == [path]


def test_without_imageio_ffmpeg_an_avi_video_is_still_written(tmp_path, monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "imageio_ffmpeg" else real(name, *a)
    )
    path = write_video(tmp_path / "v.avi", ramp(3), fps=30, crf=0)
    assert fourcc(path) == "FFV1"
    np.testing.assert_array_equal(VideoReader(path).read(2), ramp(3)[2])
