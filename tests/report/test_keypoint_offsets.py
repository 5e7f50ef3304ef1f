"""MediaPipe's definition offsets, measured on synthetic data: a point is expressed in its
joint's rest frame exactly; on a tiny 640x480 sequence the landmarks lie near their joints,
and the mapping's measured offsets bring them closer to the model's points."""

import numpy as np
import pytest
from hydra.utils import instantiate

from mmocap.body.keypoints import model_points, posed_points
from mmocap.body.model import BodyModel
from mmocap.errors import ConfigError
from mmocap.pipeline import open_foreground
from mmocap.report import keypoint_offsets
from mmocap.report.keypoint_offsets import (
    SKELETON,
    measure_sequence,
    offsets_table,
    rest_frame_offsets,
    sequence_config,
    triangulated_landmarks,
)
from mmocap.stages import segmentation
from mmocap.stages.keypoints import SkeletonMap
from tests.helpers import TINY

needs_mediapipe = pytest.mark.skipif(not segmentation.available(), reason="the segment extra is not installed")
NEAR_JOINT = ("LShoulder", "RShoulder", "LHip", "RHip")


def test_a_point_at_a_known_offset_from_its_joint_is_measured_back_in_the_rest_frame():
    body = BodyModel("S1")
    rng = np.random.default_rng(3)
    poses = body.clip(body.rest_pose() + np.c_[rng.uniform(-300, 300, (2, 3)), rng.uniform(-0.5, 0.5, (2, 48))])
    names = ["LHip", "RWrist", "Nose"]
    offsets = np.array([[-20.0, 10.0, 45.0], [0.0, -30.0, 12.0], [3.0, 4.0, -25.0]])
    joint, rest = model_points(body, names, offsets)
    world = posed_points(body, poses, joint, rest)
    world[1, 2] = np.nan  # a landmark not triangulated
    measured = rest_frame_offsets(body, poses, names, world)
    assert measured.shape == (2, 3, 3)
    np.testing.assert_allclose(measured[0], offsets, atol=1e-6)
    np.testing.assert_allclose(measured[1, :2], offsets[:2], atol=1e-6)
    assert np.isnan(measured[1, 2]).all()
    # the offset is the rest frame's, not the world's: the posed point moved away from it
    assert np.abs((world[0] - posed_points(body, poses[:1], joint, rest - offsets)[0]) - offsets).max() > 1


def tiny_overrides(root) -> list[str]:
    """The tiny sequence at 640x480 (at 320x240 MediaPipe misses the greyscale cameras'
    person) with every camera, as the command measures (with two or three, one camera's
    left-right swap cannot be outvoted), 2 frames, under ``root``, its foreground cached
    there too."""
    return [
        f"dataset.root={root}",
        "dataset.width=640",
        "dataset.height=480",
        f"dataset.background_frames={TINY['background_frames']}",
        f"dataset.seed={TINY['seed']}",
        f"foreground_cache={root / 'cache'}",
    ]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """The tiny sequence's overrides and its measured offsets, (2, K, 3) mm."""
    overrides = tiny_overrides(tmp_path_factory.mktemp("keypoint_offsets"))
    return overrides, measure_sequence(sequence_config("S1", "walking", 2, overrides), SkeletonMap.of(SKELETON))


@needs_mediapipe
def test_the_offsets_are_finite_and_the_shoulders_and_hips_lie_near_their_joints(tiny):
    _, offsets = tiny
    mapped = SkeletonMap.of(SKELETON)
    table = offsets_table({"tiny": offsets}, mapped)
    assert list(table["model point"]) == list(mapped.points)
    assert np.isfinite(table[["x (mm)", "y (mm)", "z (mm)"]].to_numpy()).all()
    assert (table["of"] == 2).all()
    assert (table["n"] >= 1).all()
    for point in NEAR_JOINT:
        k = mapped.points.index(point)
        length = np.linalg.norm(offsets[:, k], axis=1)
        assert np.isfinite(length).all(), point
        assert length.max() < 100, f"{point} landmark {length.max():.0f} mm from its joint centre"


@needs_mediapipe
def test_the_mapping_s_offsets_bring_the_landmarks_closer_to_the_model_s_points(tiny):
    overrides, _ = tiny
    mapped = SkeletonMap.of(SKELETON)
    assert np.abs(mapped.offsets_mm).max() > 0, "the mapping holds no offset"
    cfg = sequence_config("S1", "walking", 2, overrides)
    sequence = instantiate(cfg.dataset).open(progress=False)
    foreground = open_foreground(cfg, sequence, cache_dir=cfg.foreground_cache)
    found = triangulated_landmarks(foreground, mapped, float(cfg.start.keypoint_inlier_px), range(2))
    poses = np.load(sequence.root / "poses.npy")
    body = BodyModel("S1")
    distance = {}
    for name, offsets in (("without", None), ("with", mapped.offsets_mm)):
        joint, rest = model_points(body, mapped.points, offsets)
        distance[name] = np.linalg.norm(found - posed_points(body, poses, joint, rest), axis=2)
    seen = np.isfinite(distance["with"])
    assert seen.sum() >= 0.8 * seen.size
    without, with_offsets = distance["without"][seen].mean(), distance["with"][seen].mean()
    assert with_offsets < without, f"{with_offsets:.1f} mm with the mapping's offsets, {without:.1f} mm without"


@needs_mediapipe
def test_the_command_prints_the_tables_and_writes_the_page(tiny, tmp_path, monkeypatch, capsys):
    overrides, _ = tiny
    monkeypatch.setattr(keypoint_offsets, "ACTIONS", ("walking",))  # the tiny sequence, its landmarks cached
    page = tmp_path / "keypoint_offsets.md"
    keypoint_offsets.main(
        ["--frames", "2", "--no-progress", "--page", str(page), *overrides], "mmocap keypoint-offsets"
    )
    printed = capsys.readouterr().out
    assert "| left_hip " in printed
    assert "S1 walking" in printed
    text = page.read_text()
    assert text.startswith("Generated by `make keypoint-offsets` on ")
    assert "<!-- table: offsets -->" in text
    assert "<!-- table: by_sequence -->" in text
    assert "over 2 frames of S1 walking" in text


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--frames", "0"], "--frames 0"),
        (["--subjects", "S1,"], "--subjects"),
        (["--frames", "1", "realism=realistic"], "realism=exact"),
        (["--frames", "1", "dataset.nonsense=1"], "dataset.nonsense"),
    ],
)
def test_what_cannot_be_measured_is_refused_in_one_line(argv, named):
    with pytest.raises(ConfigError, match=named.replace("-", "\\-")) as error:
        keypoint_offsets.main(argv, "mmocap keypoint-offsets")
    assert "\n" not in str(error.value)
