"""Per-pixel Gaussian background model."""
import cv2
import numpy as np
import pytest

from mmocap.errors import ConfigError, DataError
from mmocap.stages.background import GaussianBackground

H, W = 120, 160
PERSON = (slice(30, 100), slice(60, 100))  # rows, columns of the rectangle "person"


def scene(rng, channels):
    """A smooth textured background with fine detail: (H, W) or (H, W, 3) float."""
    coarse = cv2.resize(rng.uniform(30, 220, (6, 8, 3)), (W, H), interpolation=cv2.INTER_CUBIC)
    image = np.clip(coarse + rng.normal(0, 12, (H, W, 3)), 0, 255)
    return image if channels == 3 else image.mean(axis=2)


def noisy(image, rng, sigma=2.0):
    return np.clip(image + rng.normal(0, sigma, image.shape), 0, 255).astype(np.uint8)


def iou(a, b):
    return (a & b).sum() / (a | b).sum()


@pytest.mark.parametrize("channels", [3, 1])
def test_rectangle_person_is_found(channels):
    rng = np.random.default_rng(3)
    background = scene(rng, channels)
    model = GaussianBackground().fit([noisy(background, rng) for _ in range(8)])
    person = 0.35 * scene(rng, channels)  # dark clothing with a texture of its own
    image = background.copy()
    image[PERSON] = person[PERSON]
    truth = np.zeros((H, W), bool)
    truth[PERSON] = True
    mask = model.apply(noisy(image, rng))
    assert mask.shape == (H, W) and mask.dtype == bool
    assert iou(mask, truth) > 0.9
    # the empty scene gives (almost) nothing
    assert model.apply(noisy(background, rng)).sum() < 0.01 * H * W


def test_std_is_floored_and_small_specks_are_removed():
    flat = np.full((H, W, 3), 100, np.uint8)
    model = GaussianBackground(threshold=4.0, min_sigma=3.0, close_px=0, min_area_px=20)
    model.fit([flat, flat, flat])
    np.testing.assert_array_equal(model.std, 3.0)
    np.testing.assert_array_equal(model.mean, 100.0)
    image = flat.copy()
    image[10:13, 10:13] = 200    # 9 px: removed
    image[50:60, 50:60, 1] = 113  # 100 px, |13| / 3 > 4: kept
    image[80:90, 80:90] = 112    # |12| / 3 = 4 is not above the threshold
    mask = model.apply(image)
    assert mask.sum() == 100 and mask[50:60, 50:60].all()


def test_errors_name_the_problem():
    rng = np.random.default_rng(5)
    frame = noisy(scene(rng, 3), rng)
    with pytest.raises(DataError, match="at least 2 background frames, got 1"):
        GaussianBackground().fit([frame])
    with pytest.raises(DataError, match=r"C2.*frame 1 has shape \(120, 160\)"):
        GaussianBackground().fit([frame, frame[:, :, 0]], name="C2")
    model = GaussianBackground().fit([frame, frame], name="C1")
    with pytest.raises(DataError, match=r"camera C1.*\(120, 161, 3\).*\(120, 160, 3\)"):
        model.apply(np.zeros((H, W + 1, 3), np.uint8), name="C1")
    with pytest.raises(DataError, match=r"\(120, 160\).*\(120, 160, 3\)"):
        model.apply(frame[:, :, 0])
    with pytest.raises(RuntimeError, match="before fit"):
        GaussianBackground().apply(frame)
    for kwargs in ({"threshold": 0}, {"min_sigma": -1.0}, {"open_px": -1}, {"close_px": 2.5},
                   {"min_area_px": "50"}, {"threshold": float("nan")}):
        with pytest.raises(ConfigError, match=next(iter(kwargs))):
            GaussianBackground(**kwargs)
