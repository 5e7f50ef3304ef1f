# TEMPLATE: rename the class ChangemeCocoDetector and its name changeme-coco (also in
# pyproject.toml and tests/), then put your own detector where the comments say.
"""A 2-D keypoint detector: one image in, one row per joint of a known skeleton out.

mmocap runs it on every frame of every camera when ``keypoints.source=detector`` and
``keypoints.detector=changeme-coco``, maps its joints onto the body model's points
(``mmocap.data.skeletons.MAPPINGS``), undistorts them and adds them to the fitness. It
needs:

- ``skeleton``: the name of the skeleton it finds, one of ``mmocap.data.skeletons.SKELETONS``
  (HALPE_26, COCO_17, BODY_25, MEDIAPIPE_33): its rows are that skeleton's joints in order;
- ``__call__(image)``: (H, W, 3) BGR or (H, W) grey uint8, as recorded (with the lens's
  distortion) -> (J, 3) float: ``u, v`` in pixels of that image and a confidence in
  [0, 1]; all zeros for a joint, or a person, not found;
- optionally ``unavailable()``: why it cannot run here (a missing library or model), or None.

This example answers in the COCO_17 skeleton (what MMPose, RTMPose, ViTPose and YOLO-pose
detectors give): it runs MediaPipe Pose, as mmocap's built-in ``mediapipe`` detector does,
and keeps the 17 of its 33 landmarks that are COCO's joints, in COCO's order.
"""

from __future__ import annotations

import numpy as np

from mmocap.stages import segmentation

#: COCO_17's joints, in its order, as MediaPipe names them
COCO_FROM_MEDIAPIPE = (
    "nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder", "right_shoulder",
    "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hip", "right_hip",
    "left_knee", "right_knee", "left_ankle", "right_ankle",
)  # fmt: skip


class ChangemeCocoDetector:
    """COCO's 17 keypoints per image, from MediaPipe Pose.

    Args:
        min_detection_confidence: the person detector's score below which nobody is found, in [0, 1].
    """

    skeleton = "COCO_17"  # your detector's skeleton

    @classmethod
    def unavailable(cls) -> str | None:
        """Why this detector cannot run here (a missing library, and what to install), or None;
        ``mmocap list`` shows it."""
        return None if segmentation.available() else f"needs MediaPipe: {segmentation.INSTALL}"

    def __init__(self, min_detection_confidence: float = 0.5):
        # your model is loaded here, once
        self.segmenter = segmentation.PersonSegmenter(min_detection_confidence=min_detection_confidence)
        self.rows = [segmentation.LANDMARK_NAMES.index(name) for name in COCO_FROM_MEDIAPIPE]

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """(H, W, 3) BGR or (H, W) grey image -> (17, 3) ``u, v`` px and confidence in [0, 1]."""
        # your detector runs here
        _, landmarks = self.segmenter.find_person(image)
        if landmarks is None:
            return np.zeros((len(self.rows), 3))
        return landmarks[self.rows].astype(np.float64)
