"""Foreground stage: packed masks, the per-frame cache, undistortion, the OpenCL upload."""

import functools
import os
import pickle
import shutil
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

from mmocap import config as mmocap_config
from mmocap.bitmask import ForegroundMask, pack_rows, unpack_rows
from mmocap.data.sequence import Sequence
from mmocap.data.synthetic import generate
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.stages.background import HorprasertBackground
from mmocap.stages.foreground import Foreground, ForegroundCoverage


class CountingHorprasert(HorprasertBackground):
    """The Horprasert model, counting the images it segments (class-wide)."""

    applied = 0

    def apply(self, image, name=None):
        type(self).applied += 1
        return super().apply(image, name)


def reference_bits(mask: np.ndarray) -> np.ndarray:
    """Word x // 32 of row y has bit x % 32 set where mask[y, x]: built pixel by pixel."""
    H, W = mask.shape
    words = np.zeros((H, (W + 31) // 32), np.uint64)
    ys, xs = np.nonzero(mask)
    np.bitwise_or.at(words, (ys, xs // 32), np.left_shift(np.uint64(1), (xs % 32).astype(np.uint64)))
    return words.astype(np.uint32)


def iou(a, b):
    return (a & b).sum() / (a | b).sum()


@pytest.fixture
def sequence(tiny_sequence, tmp_path) -> Sequence:
    """A private copy of the tiny sequence (the tests touch its files)."""
    return Sequence.open(shutil.copytree(tiny_sequence, tmp_path / "seq"))


@pytest.fixture(autouse=True)
def reset_counter():
    CountingHorprasert.applied = 0


@pytest.mark.parametrize("width", [1, 31, 32, 33, 70, 640])
def test_packed_rows_are_the_bit_layout_and_unpack(width):
    mask = np.random.default_rng(width).random((5, width)) < 0.4
    packed = pack_rows(mask)
    assert packed.dtype == np.dtype("<u4")
    assert packed.shape == (5, (width + 31) // 32)
    np.testing.assert_array_equal(packed, reference_bits(mask))
    np.testing.assert_array_equal(unpack_rows(packed, width), mask)


def test_foreground_mask_carries_its_bits_and_area():
    plain = np.random.default_rng(1).random((24, 70)) < 0.3
    mask = ForegroundMask(plain)
    assert mask.shape == (24, 70)
    assert mask.dtype == bool
    assert mask.area == plain.sum()
    np.testing.assert_array_equal(mask.packed, reference_bits(plain))
    assert mask[2:].packed is None
    assert (~mask).area is None
    again = pickle.loads(pickle.dumps(mask))
    np.testing.assert_array_equal(again.packed, mask.packed)
    assert again.area == mask.area
    with pytest.raises(ValueError, match=r"\(H, W\)"):
        ForegroundMask(np.zeros((2, 3, 4), bool))


def test_opencl_uploads_the_packed_rows_as_they_are():
    pytest.importorskip("pyopencl")
    from mmocap.evaluators import opencl_layout

    mask = ForegroundMask(np.random.default_rng(2).random((48, 70)) < 0.5)
    size = 48 * 8 + 5  # rows of 3 words widened to 8, then 5 spare words
    packed = opencl_layout.pack_bits(mask, size, mask.packed)
    np.testing.assert_array_equal(packed, opencl_layout.pack_bits(np.asarray(mask), size))
    rows = packed[: 48 * 8].reshape(48, 8)
    np.testing.assert_array_equal(rows[:, :3], reference_bits(mask))
    assert not rows[:, 3:].any()
    assert not packed[48 * 8 :].any()


def test_opencl_counts_the_same_from_foreground_masks():
    pytest.importorskip("pyopencl")
    from mmocap.evaluators import opencl
    from mmocap.testing.evaluators import RIGS, BlobBody, masks, test_poses

    try:
        ev = opencl.OpenCLEvaluator()
    except ConfigError:
        pytest.skip("no OpenCL platform on this machine")
    rig = "front-side-near"
    plain = masks(rig, "true")
    X = test_poses()
    ev.setup(BlobBody(), RIGS[rig], plain)
    expected = ev.counts(X)
    foreground = [ForegroundMask(m) for m in plain]
    ev.setup(BlobBody(), RIGS[rig], foreground)
    assert all(p is m.packed for p, m in zip(ev._packed, foreground))  # used as they are
    for got, want in zip(ev.counts(X), expected):
        np.testing.assert_array_equal(got, want)
    ev.close()


def test_masks_are_undistorted_foreground_with_areas(sequence):
    fg = Foreground(sequence, HorprasertBackground, cache_dir=None)
    assert all(not cam.dist.any() for cam in fg.cameras)
    masks = fg.masks(1)
    raw = [mask for mask, _ in fg.detect(1)]
    for cam, mask, detected in zip(sequence.cameras, masks, raw):
        assert isinstance(mask, ForegroundMask)
        assert mask.shape == (cam.height, cam.width)
        assert mask.area == np.count_nonzero(mask) > 0.005 * mask.size
        np.testing.assert_array_equal(mask, cam.undistort_mask(detected))
        np.testing.assert_array_equal(mask.packed, pack_rows(mask))
        # the background model finds the person (3 background frames, small images)
        assert iou(detected, sequence.silhouette(1, cam)) > 0.7, cam.name


def test_cache_hit_miss_and_invalidation(sequence, tmp_path):
    cache = tmp_path / "cache"
    make = functools.partial(CountingHorprasert, detection_rate=0.999)
    first = Foreground(sequence, make, cache_dir=cache)
    computed = [first.masks(f) for f in range(sequence.n_frames)]
    cams = len(sequence.cameras)
    assert CountingHorprasert.applied == sequence.n_frames * cams
    assert first.cache.misses == 4
    files = sorted(p.name for p in first.cache.folder.iterdir())
    assert files == [f"{f:06d}.npz" for f in range(sequence.n_frames)]  # no temporary left

    # hit: a new run reads every frame back, fits no model and segments nothing
    second = Foreground(sequence, make, cache_dir=cache)
    for f in range(sequence.n_frames):
        for a, b in zip(computed[f], second.masks(f)):
            np.testing.assert_array_equal(a, b)
            np.testing.assert_array_equal(a.packed, b.packed)
            assert a.area == b.area
    assert CountingHorprasert.applied == sequence.n_frames * cams
    assert second.cache.hits == sequence.n_frames
    assert second._models is None

    # another background configuration: another folder, computed again
    other = Foreground(sequence, functools.partial(CountingHorprasert, detection_rate=0.99), cache_dir=cache)
    assert other.cache.folder != first.cache.folder
    other.masks(0)
    assert CountingHorprasert.applied == (sequence.n_frames + 1) * cams

    # a re-rendered sequence (sequence.json rewritten): another folder too
    meta = sequence.root / "sequence.json"
    stat = meta.stat()
    os.utime(meta, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    assert Foreground(sequence, make, cache_dir=cache).cache.folder != first.cache.folder

    # images given by the caller bypass the cache
    before = CountingHorprasert.applied
    second.masks(0, images=sequence.images(0))
    assert CountingHorprasert.applied == before + cams


def test_a_damaged_cache_file_is_recomputed_and_replaced(sequence, tmp_path):
    fg = Foreground(sequence, CountingHorprasert, cache_dir=tmp_path)
    good = fg.masks(2)
    fg.cache.path(2).write_bytes(b"not an npz")
    again = Foreground(sequence, CountingHorprasert, cache_dir=tmp_path)
    for a, b in zip(good, again.masks(2)):
        np.testing.assert_array_equal(a, b)
    assert again.cache.misses == 1
    assert Foreground(sequence, CountingHorprasert, cache_dir=tmp_path).cache.load(2) is not None


def test_default_cache_is_in_outputs_and_follows_the_background_frames(sequence, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    fg = Foreground(sequence, HorprasertBackground)
    fg.masks(0)
    assert fg.cache.path(0).is_file()
    assert fg.cache.folder.parent == Path("outputs/cache/foreground")
    # another empty scene (same metadata and files' times): another key
    path = sorted((sequence.root / "background" / "C1").glob("*.png"))[0]
    stat = path.stat()
    image = cv2.imread(str(path))
    cv2.imwrite(str(path), 255 - image)
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert Foreground(sequence, HorprasertBackground).cache.folder != fg.cache.folder


def test_unwritable_cache_folder_only_turns_the_cache_off(sequence, tmp_path, caplog):
    blocker = tmp_path / "file"
    blocker.write_text("a file where the cache folder should go")
    fg = Foreground(sequence, HorprasertBackground, cache_dir=blocker)
    masks = fg.masks(0)
    assert len(masks) == len(sequence.cameras)
    assert "not writable" in caplog.text


def test_undistorted_masks_match_a_distortion_free_rendering(tmp_path):
    """The same scene rendered through the lens and through ideal pin-holes."""
    kwargs = dict(
        subject="S1",
        action="walking",
        frames=1,
        cameras=("C1", "BW1"),
        width=320,
        height=240,
        background_frames=4,
        seed=3,
        progress=False,
    )
    lens = Sequence.open(generate(tmp_path / "lens", distortion=1.0, **kwargs))
    ideal = Sequence.open(generate(tmp_path / "ideal", distortion=0.0, **kwargs))
    lens_fg = Foreground(lens, HorprasertBackground, cache_dir=None)
    ideal_fg = Foreground(ideal, HorprasertBackground, cache_dir=None)
    for c, (cam, ideal_cam) in enumerate(zip(lens.cameras, ideal.cameras)):
        np.testing.assert_allclose(cam.ideal().K, ideal_cam.K)
        through_lens = lens.silhouette(0, cam)
        truth = ideal.silhouette(0, ideal_cam)
        undistorted = cam.undistort_mask(through_lens)
        # at 320x240 a pixel of the outline is ~2 % of a silhouette's area
        assert iou(undistorted, truth) > max(0.94, iou(through_lens, truth)), cam.name
        assert iou(lens_fg.masks(0)[c], ideal_fg.masks(0)[c]) > 0.85, cam.name


@pytest.mark.slow
def test_tracking_through_the_lens_matches_a_distortion_free_rendering(tmp_path, monkeypatch):
    """The demo's tracking on the same sequence rendered with its lens distortion (masks
    undistorted by this stage) and through ideal pin-holes: the errors agree within 3 mm."""
    from mmocap.pipeline import run

    monkeypatch.chdir(tmp_path)
    errors = {}
    for distortion in (1.0, 0.0):
        cfg = mmocap_config.compose(
            [
                "+experiment=demo",
                f"dataset.root={tmp_path / f'data{distortion}'}",
                f"dataset.distortion={distortion}",
                "dataset.frames=10",
                "dataset.all_cameras=${dataset.cameras}",
                "overlays=0",
                "progress=false",
            ]
        )
        errors[distortion] = run(cfg, tmp_path / f"run{distortion}")["mean_marker_error_mm"]
    assert errors[0.0] < 25
    assert abs(errors[1.0] - errors[0.0]) < 3, errors


def test_quality_table_scores_each_method_per_camera(sequence):
    from mmocap.report.foreground_quality import (
        confusion,
        quality_table,
        scores,
        to_markdown,
    )
    from mmocap.stages.background import GaussianBackground

    truth = np.zeros((4, 5), bool)
    truth[1:3, 1:4] = True  # 6 px
    mask = np.zeros((4, 5), bool)
    mask[1:3, 2:5] = True  # 6 px, 4 of them on the truth
    np.testing.assert_array_equal(confusion(mask, truth), [4, 2, 2])
    np.testing.assert_allclose(scores(np.array([4, 2, 2])), [4 / 6, 4 / 6, 4 / 8])
    assert np.isnan(scores(np.zeros(3))).all()

    table = quality_table(sequence, {"horprasert": HorprasertBackground, "gaussian": GaussianBackground}, frames=[0, 3])
    names = [cam.name for cam in sequence.cameras]
    assert list(table["camera"]) == [*names, "all"] * 2
    assert list(table["method"]) == ["horprasert"] * 4 + ["gaussian"] * 4
    assert table[["precision", "recall", "iou"]].stack().between(0, 1).all()
    ours = table[table["method"] == "horprasert"].set_index("camera")
    assert ours.loc["all", "iou"] > 0.7
    text = to_markdown(table)
    assert text.splitlines()[0] == "| camera | horprasert P / R / IoU | gaussian P / R / IoU |"
    assert len(text.splitlines()) == 2 + len(names) + 1


def test_quality_command_writes_the_tables(tiny_sequence, tmp_path, capsys):
    from tests.helpers import TINY, run_cli

    shutil.copytree(tiny_sequence, tmp_path / "data" / "S1_walking")
    cameras = "[" + ",".join(TINY["cameras"]) + "]"
    overrides = [
        f"dataset.root={tmp_path / 'data'}",
        f"dataset.frames={TINY['frames']}",
        f"dataset.cameras={cameras}",
        f"dataset.all_cameras={cameras}",
        f"dataset.width={TINY['width']}",
        f"dataset.height={TINY['height']}",
        f"dataset.background_frames={TINY['background_frames']}",
        f"dataset.seed={TINY['seed']}",
        "progress=false",
    ]
    csv, md = tmp_path / "t" / "fg.csv", tmp_path / "t" / "fg.md"
    # options and overrides intermixed
    assert (
        run_cli(
            "foreground-quality",
            *overrides[:3],
            "--methods",
            "horprasert,mog2",
            "--csv",
            csv,
            *overrides[3:],
            "--md",
            md,
        )
        == 0
    )
    table = pd.read_csv(csv)
    assert list(table.columns) == ["method", "camera", "precision", "recall", "iou"]
    assert len(table) == 2 * (len(TINY["cameras"]) + 1)
    assert md.read_text() == capsys.readouterr().out
    assert "S1 walking (4 frames)" in md.read_text()
    for args in (
        ["--methods", "horprasert", "background.detection_rate=2"],  # out of range
        ["background.detection_rate=0.99"],
    ):  # not in mog2
        assert run_cli("foreground-quality", *overrides, "--csv", csv, "--md", md, *args) == 2
        err = capsys.readouterr().err
        assert err.startswith("mmocap: error:")
        assert "background.detection_rate" in err


class _Cam:
    def __init__(self, name):
        self.name = name


def _mask(fraction: float, shape=(100, 100)) -> np.ndarray:
    """A (H, W) bool mask with ``fraction`` of its pixels set."""
    mask = np.zeros(shape, bool)
    mask.flat[: round(fraction * mask.size)] = True
    return mask


def test_coverage_flags_a_camera_only_after_frames_in_a_row():
    check = ForegroundCoverage(action="stop", frames=3)
    cams = [_Cam("A"), _Cam("B")]
    person = _mask(0.05)
    sparse = _mask(0.0005)  # below min_fraction, not empty
    for frame, b in enumerate([sparse, sparse, person, sparse, sparse]):  # streaks of 2 only
        kept, masks = check.select(frame, cams, [person, b], last_frame=9)
        assert [c.name for c in kept] == ["A", "B"]
        assert len(masks) == 2
    with pytest.raises(DataError, match=r"camera B: foreground covers 0.05% .* frames 3-5"):
        check.select(5, cams, [person, sparse], last_frame=9)


def test_an_empty_mask_leaves_its_camera_out_of_that_frame_only_and_is_reported():
    check = ForegroundCoverage(action="stop", frames=3)
    cams = [_Cam("A"), _Cam("B")]
    person, empty = _mask(0.05), _mask(0.0)
    for frame, b in enumerate([empty, person, empty, empty, empty, empty]):  # empty frames never stop it
        kept, masks = check.select(frame, cams, [person, b], last_frame=9)
        assert [c.name for c in kept] == (["A", "B"] if b is person else ["A"])
        assert len(masks) == len(kept)
    assert check.skipped == {"B": [0, 2, 3, 4, 5]}
    with pytest.warns(MmocapWarning, match=r"camera B: nobody in its foreground in 5 of 6 frames \(0, 2-5\)"):
        check.warn_skipped(6)
    with pytest.raises(DataError, match="no camera left.*nobody in the foreground of: A, B"):
        check.select(6, cams, [empty, empty], last_frame=9)


def test_coverage_drop_keeps_tracking_with_the_other_cameras_until_none_is_left():
    check = ForegroundCoverage(action="drop", frames=1)
    cams = [_Cam("A"), _Cam("B")]
    with pytest.warns(MmocapWarning, match="camera B: foreground covers 90.00%.*dropped"):
        kept, masks = check.select(0, cams, [_mask(0.05), _mask(0.9)], last_frame=5)
    assert [c.name for c in kept] == ["A"]
    assert masks[0].mean() == pytest.approx(0.05)
    kept, _ = check.select(1, cams, [_mask(0.05), _mask(0.05)], last_frame=5)
    assert [c.name for c in kept] == ["A"]  # a dropped camera stays dropped
    with pytest.warns(MmocapWarning), pytest.raises(DataError, match="no camera left"):
        check.select(2, cams, [_mask(0.0005), _mask(0.05)], last_frame=5)


def test_coverage_flags_a_camera_faulty_over_the_whole_of_a_short_run():
    check = ForegroundCoverage(frames=5)
    check.select(0, [_Cam("A")], [_mask(0.0005)], last_frame=1)
    with pytest.raises(DataError, match="frames 0-1"):
        check.select(1, [_Cam("A")], [_mask(0.0005)], last_frame=1)


@pytest.mark.parametrize(
    ("kwargs", "key"),
    [
        ({"action": "warn"}, "coverage.action"),
        ({"min_fraction": -0.1}, "coverage.min_fraction"),
        ({"min_fraction": 0.6, "max_fraction": 0.5}, "coverage.max_fraction"),
        ({"frames": 0}, "coverage.frames"),
    ],
)
def test_coverage_settings_are_checked(kwargs, key):
    with pytest.raises(ConfigError, match=key):
        ForegroundCoverage(**kwargs)
