"""The synthetic benchmark scene: a body at a vertex level seen by cameras of the synthetic
ring (no lens distortion), the foreground being the model's own silhouettes of a reference
pose, packed as the foreground stage gives it (a tracked frame packs its masks there, not in
the search); candidates are that pose with normal noise on the joint angles. The evaluator
benchmark (:mod:`mmocap.bench`) times the backends on it, and the golden tests count its
pixels."""

from __future__ import annotations

from typing import Any

import numpy as np

from mmocap import registry
from mmocap.bitmask import ForegroundMask
from mmocap.body.model import BodyModel
from mmocap.data.synthetic import CAMERA_RING, camera_rig


class Scene:
    """Body at a vertex level, ``cameras`` 640x480 cameras and their foreground masks."""

    def __init__(self, vertices: int, cameras: int = 7, seed: int = 0):
        rng = np.random.default_rng(seed)
        self.body = BodyModel(vertices=vertices)
        names = [name for name, _, _ in CAMERA_RING][:cameras]
        self.cameras = camera_rig(names, 640, 480, rng, distortion=0.0)
        self.pose = self.body.rest_pose() + self.noise(rng, 1, 0.15)[0]
        with registry.make_evaluator("numpy") as ev:
            ev.setup(self.body, self.cameras, [np.zeros((480, 640), bool)] * cameras)
            self.foreground = [ForegroundMask(ev.render(self.pose, c)) for c in range(cameras)]

    def noise(self, rng: np.random.Generator, n: int, radians: float) -> np.ndarray:
        """(n, 51) normal noise of ``radians`` on the active joint angles, none on the root."""
        scale = np.where(np.arange(51) >= 6, radians, 0.0) * self.body.mask
        return rng.normal(0.0, 1.0, (n, 51)) * scale

    def candidates(self, n: int, seed: int = 1) -> np.ndarray:
        """(n, 51) poses around the reference pose."""
        return self.pose + self.noise(np.random.default_rng(seed), n, 0.05)


#: the synthetic sequence the detector conformance suite renders (:func:`mmocap.data.synthetic.generate`
#: settings): 640x480, a colour and a greyscale camera, 2 frames
CONFORMANCE_SEQUENCE: dict[str, Any] = dict(
    subject="S1",
    action="walking",
    frames=2,
    cameras=("C1", "BW1"),
    width=640,
    height=480,
    background_frames=2,
    seed=5,
)
