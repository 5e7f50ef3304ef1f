"""Background models: Gaussian, Horprasert, OpenCV MOG2 and KNN, and the shared clean-up."""

import cv2
import numpy as np
import pytest

from mmocap.errors import ConfigError, DataError
from mmocap.stages.background import (
    FOREGROUND,
    HIGHLIGHT,
    SHADOW,
    Cleanup,
    GaussianBackground,
    HorprasertBackground,
    OpenCVBackground,
)

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
    assert mask.shape == (H, W)
    assert mask.dtype == bool
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
    image[10:13, 10:13] = 200  # 9 px: removed
    image[50:60, 50:60, 1] = 113  # 100 px, |13| / 3 > 4: kept
    image[80:90, 80:90] = 112  # |12| / 3 = 4 is not above the threshold
    mask = model.apply(image)
    assert mask.sum() == 100
    assert mask[50:60, 50:60].all()


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
    for kwargs in (
        {"threshold": 0},
        {"min_sigma": -1.0},
        {"open_px": -1},
        {"close_px": 2.5},
        {"min_area_px": "50"},
        {"threshold": float("nan")},
    ):
        with pytest.raises(ConfigError, match=next(iter(kwargs))):
            GaussianBackground(**kwargs)


# --- Horprasert, OpenCV subtractors, clean-up -------------------------------------------

REGION = (slice(20, 60), slice(20, 70))
REGION_TRUTH = np.zeros((H, W), bool)
REGION_TRUTH[REGION] = True


def fitted(model, channels, seed=7, frames=10):
    """``model`` fit on noisy frames of a textured scene; returns (model, scene, rng)."""
    rng = np.random.default_rng(seed)
    background = scene(rng, channels)
    model.fit([noisy(background, rng) for _ in range(frames)], name="C1")
    return model, background, rng


def soft_light(image, factor):
    """``image`` under a soft-edged pool of light: a Gaussian blob (sigma 15 px) centred on
    REGION whose centre multiplies the light by ``factor``; also returns the (H, W) light."""
    rows, cols = np.mgrid[:H, :W]
    light = 1 + (factor - 1) * np.exp(-((rows - 40) ** 2 + (cols - 45) ** 2) / (2 * 15.0**2))
    return image * (light[..., None] if image.ndim == 3 else light), light


def label_fractions(model, image, rng, where):
    """Fraction of the pixels ``where`` (H, W) bool with each label."""
    return np.bincount(model.classify(noisy(image, rng))[where], minlength=4) / where.sum()


def labels_in_region(model, image, rng):
    return label_fractions(model, image, rng, REGION_TRUTH)


@pytest.mark.parametrize("channels", [3, 1])
def test_horprasert_tells_shadow_and_highlight_from_foreground(channels):
    model, background, rng = fitted(HorprasertBackground(), channels)
    shaded, light = soft_light(background, 0.65)  # a shadow: the same texture, darker
    assert label_fractions(model, shaded, rng, light < 0.9)[SHADOW] > 0.95
    assert not model.apply(noisy(shaded, rng)).any()
    lit, light = soft_light(background, 1.25)  # a highlight: brighter
    assert label_fractions(model, lit, rng, light > 1.1)[HIGHLIGHT] > 0.95
    assert not model.apply(noisy(lit, rng)).any()
    person = background.copy()  # about as bright, another pattern or colour
    other = scene(np.random.default_rng(99), channels)
    person[REGION] = (other[..., ::-1] if channels == 3 else 0.8 * other)[REGION]
    assert labels_in_region(model, person, rng)[FOREGROUND] > 0.8
    assert iou(model.apply(noisy(person, rng)), REGION_TRUTH) > 0.9
    dark = background.copy()
    dark[REGION] *= 0.3  # darker than any shadow: foreground
    assert labels_in_region(model, dark, rng)[FOREGROUND] > 0.95


@pytest.mark.parametrize("channels", [3, 1])
def test_horprasert_thresholds_come_from_the_background_frames(channels):
    model, background, rng = fitted(HorprasertBackground(detection_rate=0.999, close_px=0, min_area_px=0), channels)
    assert model.tau_alpha_low < 0 < model.tau_alpha_high
    assert model.tau_cd > 0
    # on new frames of the empty scene about 1 - detection_rate of the pixels are foreground
    raw = np.mean([model.classify(noisy(background, rng)) == FOREGROUND for _ in range(3)])
    assert raw < 0.005
    strict, *_ = fitted(HorprasertBackground(detection_rate=0.9), channels)
    assert strict.tau_cd < model.tau_cd
    assert strict.tau_alpha_high < model.tau_alpha_high


def test_horprasert_greyscale_without_window_uses_brightness_only():
    model, background, rng = fitted(HorprasertBackground(grey_window_px=1), 1)
    _, cd = model.distortions(noisy(background, rng))
    np.testing.assert_allclose(cd, 0, atol=0.1)  # one channel: CD is undefined (always 0)
    shaded, light = soft_light(background, 0.65)
    assert label_fractions(model, shaded, rng, light < 0.9)[SHADOW] > 0.95


@pytest.mark.parametrize("channels", [3, 1])
def test_horprasert_holds_on_images_noisier_than_a_frozen_plate(channels):
    # as a codec leaves them: the empty scene encoded once and copied frame to frame (its
    # frames differ by far less than the sensor's noise), each image of the person with its own noise
    rng = np.random.default_rng(3)
    background = scene(rng, channels)
    frozen = noisy(background, rng).astype(float)
    plate = [noisy(frozen, rng, sigma=0.5) for _ in range(10)]
    person = background.copy()
    person[REGION] = 0.4 * scene(np.random.default_rng(99), channels)[REGION]
    image = noisy(person, rng)
    model = HorprasertBackground().fit(plate)
    assert model.codec_noise(model.distortions(image)[1]) > 0
    assert model.codec_noise(model.distortions(noisy(frozen, rng, sigma=0.5))[1]) == 0  # as the plate's frames
    assert iou(model.apply(image), REGION_TRUTH) > 0.9
    ungated = HorprasertBackground(codec_threshold=1e-9).fit(plate)
    assert ungated.apply(image).mean() > 0.5  # the plate's spread alone: noise everywhere is foreground


@pytest.mark.parametrize("channels", [3, 1])
def test_horprasert_images_as_noisy_as_the_background_frames_are_not_gated(channels):
    model, background, rng = fitted(HorprasertBackground(), channels)
    ungated, *_ = fitted(HorprasertBackground(codec_threshold=1e9), channels)
    person = background.copy()
    other = scene(np.random.default_rng(99), channels)
    person[REGION] = (other[..., ::-1] if channels == 3 else 0.8 * other)[REGION]
    for image in (noisy(background, rng), noisy(person, rng)):
        np.testing.assert_array_equal(model.classify(image), ungated.classify(image))


@pytest.mark.parametrize("method", ["mog2", "knn"])
@pytest.mark.parametrize("channels", [3, 1])
def test_opencv_subtractors_find_the_person_and_do_not_learn_it(method, channels):
    model, background, rng = fitted(
        OpenCVBackground(method=method, threshold=16.0 if method == "mog2" else 400.0), channels
    )
    image = background.copy()
    image[PERSON] = 0.35 * scene(rng, channels)[PERSON]
    truth = np.zeros((H, W), bool)
    truth[PERSON] = True
    first = model.apply(noisy(image, rng))
    assert iou(first, truth) > 0.9
    for _ in range(5):  # applied without learning
        model.apply(image.astype(np.uint8))
    assert iou(model.apply(noisy(image, rng)), truth) > 0.9


def test_cleanup_keeps_the_largest_component_and_drops_small_ones():
    mask = np.zeros((H, W), bool)
    mask[10:40, 10:40] = True  # 900 px
    mask[60:75, 100:115] = True  # 225 px
    mask[100:103, 5:8] = True  # 9 px
    assert Cleanup(close_px=0, min_area_px=20)(mask).sum() == 900 + 225
    largest = Cleanup(close_px=0, min_area_px=0, largest_only=True)(mask)
    assert largest.sum() == 900
    assert largest[10:40, 10:40].all()
    assert not Cleanup(largest_only=True)(np.zeros((H, W), bool)).any()
    holed = mask.copy()
    holed[20, 20] = False
    assert Cleanup(close_px=3, min_area_px=0)(holed)[20, 20]


@pytest.mark.parametrize("make", [HorprasertBackground, GaussianBackground, lambda: OpenCVBackground(method="knn")])
def test_short_or_inconsistent_background_sets_name_the_camera(make):
    rng = np.random.default_rng(5)
    frame = noisy(scene(rng, 3), rng)
    needed = make().min_frames
    with pytest.raises(DataError, match=rf"camera BW2: .* at least {needed} background frames, got 1"):
        make().fit([frame], name="BW2")
    with pytest.raises(DataError, match=r"camera C3: background frame 2 has shape \(120, 80, 3\)"):
        make().fit([frame, frame, frame[:, :80], frame], name="C3")
    with pytest.raises(DataError, match=r"camera C3: background frame 0 has shape \(120, 160, 3, 1\)"):
        make().fit([frame[..., None]] * 4, name="C3")


@pytest.mark.parametrize(
    ("make", "kwargs"),
    [
        (HorprasertBackground, {"detection_rate": 1.5}),
        (HorprasertBackground, {"detection_rate": 0}),
        (HorprasertBackground, {"min_sigma": -1.0}),
        (HorprasertBackground, {"shadow_min_alpha": 1.2}),
        (HorprasertBackground, {"highlight_max_alpha": 0.9}),
        (HorprasertBackground, {"grey_window_px": 4}),
        (HorprasertBackground, {"codec_threshold": 0}),
        (HorprasertBackground, {"open_px": -1}),
        (HorprasertBackground, {"largest_only": "yes"}),
        (OpenCVBackground, {"method": "vibe"}),
        (OpenCVBackground, {"threshold": -3.0}),
        (OpenCVBackground, {"detect_shadows": 1}),
    ],
)
def test_bad_config_values_name_the_parameter(make, kwargs):
    with pytest.raises(ConfigError, match=f"background.{next(iter(kwargs))}"):
        make(**kwargs)


def test_horprasert_greyscale_absorbs_a_penumbra_across_the_window():
    model, background, rng = fitted(HorprasertBackground(close_px=0, min_area_px=0), 1)
    light = np.full((H, W), 0.6)
    light[:, :40] = 1.0
    light[:, 40:80] = np.linspace(1.0, 0.6, 40)  # brightness falls 1 % per pixel
    labels = model.classify(noisy(background * light, rng))
    assert np.mean(labels[:, 50:] == SHADOW) > 0.95
    assert np.mean(labels == FOREGROUND) < 0.005
