"""The 3-D skeleton pictures of a run (mmocap.writers.skeleton): the strip and the animation."""

import numpy as np
import pytest
from PIL import Image, ImageSequence

from mmocap.body.skeleton import PARENT_INDEX
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.writers import skeleton
from tests.helpers import assert_fits


def walking(frames: int) -> np.ndarray:
    """(frames, 16, 3) mm: a stick figure stepping forward (+z), its left wrist swinging."""
    rest = np.array(
        [
            [0, 950, 0],
            [0, 1000, -26],
            [0, 1230, -23],
            [190, 1430, 0],
            [200, 1180, 0],
            [210, 940, 20],
            [-190, 1430, 0],
            [-200, 1180, 0],
            [-210, 940, 20],
            [0, 1350, -8],
            [118, 925, 0],
            [130, 480, 20],
            [135, 80, -15],
            [-118, 925, 0],
            [-130, 480, 20],
            [-135, 80, -15],
        ],
        dtype=float,
    )
    joints = np.repeat(rest[None], frames, axis=0)
    joints[..., 2] += np.linspace(0, 1200, frames)[:, None]
    joints[:, 5, 2] += 200 * np.sin(np.linspace(0, 2 * np.pi, frames))
    return joints


def test_skeleton_strip_draws_evenly_spaced_frames_on_equal_scales(tmp_path):
    path = tmp_path / "strip.png"
    fig = skeleton.plot_skeleton_strip(walking(30), PARENT_INDEX, path, "S1 walking")
    assert_fits(fig, path)
    panels = skeleton.SKELETON_STRIP_FRAMES
    width, height = skeleton.SKELETON_PANEL_INCHES
    with Image.open(path) as image:
        assert image.size == (round(panels * width * skeleton.SKELETON_DPI), round(height * skeleton.SKELETON_DPI))
    assert [ax.get_title() for ax in fig.axes] == [f"frame {f}" for f in (0, 4, 8, 12, 17, 21, 25, 29)]
    scales = [
        np.abs(np.diff([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()], axis=1)).ravel() / ax.get_box_aspect()
        for ax in fig.axes
    ]
    np.testing.assert_allclose(scales, scales[0][0])  # mm per unit of box: one for all axes and panels


def test_skeleton_strip_draws_every_bone_of_the_frames_asked_for(tmp_path):
    joints = walking(10)
    fig = skeleton.plot_skeleton_strip(joints, PARENT_INDEX, tmp_path / "s.png", "every", every=4)
    assert [ax.get_title() for ax in fig.axes] == ["frame 0", "frame 4", "frame 8"]
    bones = fig.axes[1].lines[0].get_data_3d()
    ends = np.column_stack(bones)[~np.isnan(bones[0])]  # (2 bones, 3): plot x, y, z = world x, z, y
    assert len(ends) == 2 * (len(PARENT_INDEX) - 1)
    np.testing.assert_allclose(ends[-1], joints[4, -1, [0, 2, 1]])
    fig = skeleton.plot_skeleton_strip(joints, PARENT_INDEX, tmp_path / "s.png", "frames", frames=[9, 2])
    assert [ax.get_title() for ax in fig.axes] == ["frame 9", "frame 2"]


@pytest.mark.parametrize(
    ("settings", "match"),
    [
        (dict(frames=[1], every=2), "not both"),
        (dict(frames=[10]), "frames must be an integer in"),
        (dict(every=0), "every must be an integer in"),
        (dict(frames=list(range(10)) * 3), "draws 1 to 24 frames"),
    ],
    ids=["frames and every", "frame past the end", "every zero", "too many frames"],
)
def test_skeleton_strip_settings_out_of_range_are_config_errors(tmp_path, settings, match):
    with pytest.raises(ConfigError, match=match):
        skeleton.plot_skeleton_strip(walking(10), PARENT_INDEX, tmp_path / "s.png", "bad", **settings)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("joints", "parents", "match"),
    [
        (np.zeros((3, 16)), PARENT_INDEX, r"joints_mm must be \(frames, joints, 3\)"),
        (np.zeros((3, 16, 3)), PARENT_INDEX[:-1], "parents must hold one integer per joint"),
        (np.zeros((3, 16, 3)), np.where(PARENT_INDEX == -1, 0, PARENT_INDEX), "parents must hold"),
        (
            np.where(np.arange(3)[:, None, None] == 1, np.nan, np.zeros((3, 16, 3))),
            PARENT_INDEX,
            "frames 1 have no finite joint",
        ),
    ],
    ids=["joints without xyz", "parents short", "root its own parent", "frame all NaN"],
)
def test_a_skeleton_of_the_wrong_shape_is_a_data_error(tmp_path, joints, parents, match):
    with pytest.raises(DataError, match=match):
        skeleton.plot_skeleton_strip(joints, parents, tmp_path / "s.png", "bad")


def test_skeleton_animation_gif_has_one_image_per_frame(tmp_path):
    path = skeleton.write_skeleton_animation(
        walking(5), PARENT_INDEX, tmp_path / "a.gif", fps=10, title="S1", progress=False
    )
    side = round(skeleton.SKELETON_ANIMATION_INCHES * skeleton.SKELETON_ANIMATION_DPI)
    with Image.open(path) as gif:
        frames = list(ImageSequence.Iterator(gif))
        assert len(frames) == 5
        assert gif.size == (side, side)
        assert gif.info["duration"] == 100
        assert gif.info["loop"] == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]


def test_skeleton_animation_mp4_has_one_image_per_frame(tmp_path):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    path = skeleton.write_skeleton_animation(walking(6), PARENT_INDEX, tmp_path / "a.mp4", fps=12, progress=False)
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(path))
    assert frames == 6
    assert seconds == pytest.approx(0.5)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mp4"]


def test_skeleton_animation_other_formats_are_config_errors_and_fast_gifs_warned(tmp_path):
    with pytest.raises(ConfigError, match=r"a.avi: .* \.gif or \.mp4"):
        skeleton.write_skeleton_animation(walking(2), PARENT_INDEX, tmp_path / "a.avi", fps=10, progress=False)
    with pytest.raises(ConfigError, match="fps must be a number"):
        skeleton.write_skeleton_animation(walking(2), PARENT_INDEX, tmp_path / "a.gif", fps=0, progress=False)
    with pytest.warns(MmocapWarning, match="plays at most 50 frames per second"):
        skeleton.write_skeleton_animation(walking(2), PARENT_INDEX, tmp_path / "a.gif", fps=60, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]
