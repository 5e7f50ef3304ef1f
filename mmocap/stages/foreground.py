"""Stage "foreground": per-camera background models applied to each frame, then undistorted.

The masks come out in the ideal pin-hole geometry of ``camera.ideal()`` (the Cano paper's
approach: undistort the foreground once per frame, never the model's vertices).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from mmocap.data.sequence import Sequence


class Foreground:
    """Foreground masks of a sequence.

    Args:
        sequence: the opened sequence.
        make_background: factory returning a fresh background model with ``fit(frames)``
            and ``apply(image, name=...) -> (H, W) bool`` (a Hydra ``_partial_``).
    """

    def __init__(self, sequence: Sequence, make_background: Callable):
        self.sequence = sequence
        self.models = []
        for cam in sequence.cameras:
            model = make_background()
            model.fit(sequence.background(cam), name=cam.name)
            self.models.append(model)

    @property
    def cameras(self):
        """The ideal pin-hole cameras the masks belong to."""
        return [cam.ideal() for cam in self.sequence.cameras]

    def masks(self, frame: int, images: list[np.ndarray] | None = None) -> list[np.ndarray]:
        """(H, W) bool undistorted foreground per camera for ``frame``."""
        images = self.sequence.images(frame) if images is None else images
        return [cam.undistort_mask(model.apply(img, name=cam.name))
                for cam, model, img in zip(self.sequence.cameras, self.models, images)]
