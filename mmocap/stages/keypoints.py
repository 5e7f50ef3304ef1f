"""Stage "keypoints": each frame's 2-D keypoints for the hybrid fitness (config ``keypoints``).

Where they come from (``keypoints.source``):

- ``files``: the sequence's keypoint files (``pose/<camera>_json/`` as Pose2Sim writes them,
  or ``keypoints.csv``: :mod:`mmocap.data.keypoints`), in any skeleton of
  :mod:`mmocap.data.skeletons`; synthetic sequences of the realistic and hard levels carry
  simulated ones (:mod:`mmocap.data.realism`);
- ``detector``: a detector plugin (entry-point group ``mmocap.detectors``, ``keypoints.detector``)
  run on each frame's images; MediaPipe's landmarks come free with person segmentation
  (``foreground.method=segmentation``), which finds them anyway;
- ``auto``: the files when the sequence has them, else the segmentation's landmarks when the
  foreground is segmented, else none;
- ``none``: silhouettes only, as in the papers (every paper experiment sets it).

The detector's joints are mapped onto the model's points (:data:`mmocap.data.skeletons.MAPPINGS`)
and undistorted into the ideal pin-hole cameras the masks are in. The result per frame is a
:class:`~mmocap.evaluators.keypoint_term.Keypoints` that the evaluators add to the fitness
with ``keypoints.weight``, ``.loss`` and ``.scale``
(:class:`~mmocap.evaluators.keypoint_term.KeypointTerm`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from mmocap import registry
from mmocap.data.keypoints import AUTO
from mmocap.data.skeletons import MAPPINGS, check_mapping, skeleton_joints
from mmocap.errors import ConfigError
from mmocap.evaluators.keypoint_term import LOSS, SCALE, Keypoints, KeypointTerm

log = logging.getLogger(__name__)

SOURCES = ("auto", "files", "detector", "none")
#: the detector whose landmarks person segmentation finds anyway
SEGMENTATION_DETECTOR = "mediapipe"


@dataclass(frozen=True)
class SkeletonMap:
    """Rows of a skeleton's (J, 3) detections that are model points, and those points.

    Attributes:
        skeleton: the skeleton's name (:data:`mmocap.data.skeletons.SKELETONS`).
        rows: (K,) int, the detector rows kept, in the mapping's order.
        points: K model point names.
        offsets_mm: (K, 3) definition offsets, mm, rest frame.
    """

    skeleton: str
    rows: np.ndarray
    points: tuple[str, ...]
    offsets_mm: np.ndarray

    @staticmethod
    def of(skeleton: str) -> SkeletonMap:
        """The documented mapping of ``skeleton``; ConfigError for an unknown one."""
        joints = skeleton_joints(skeleton)
        mapping = MAPPINGS[skeleton]
        check_mapping(skeleton, mapping)
        names = list(mapping)
        return SkeletonMap(
            skeleton,
            np.array([joints.index(name) for name in names]),
            tuple(mapping[name][0] for name in names),
            np.array([mapping[name][1] for name in names], np.float64),
        )


class KeypointSource:
    """Chooses where keypoints come from and makes each frame's (config ``keypoints``).

    Args:
        source: ``auto``, ``files``, ``detector`` or ``none`` (see the module docstring).
        skeleton: the files' skeleton, or ``auto`` to tell it from the joint count.
        detector: the entry-point name of the detector run for ``source=detector``.
        use_for_start: the automatic start fits the keypoints first when there are any.
        weight, loss, scale: the keypoint term's
            (:class:`~mmocap.evaluators.keypoint_term.KeypointTerm`): its weight beside the
            silhouettes (chosen by ``make keypoint_weight``), robust loss and the loss's scale
            as a share of the person's image height.
    """

    def __init__(
        self,
        source: str = "auto",
        skeleton: str = AUTO,
        detector: str = SEGMENTATION_DETECTOR,
        use_for_start: bool = True,
        weight: float = 0.5,
        loss: str = LOSS,
        scale: float = SCALE,
    ):
        if source not in SOURCES:
            raise ConfigError(f"keypoints.source must be one of {', '.join(SOURCES)}, got {source!r}")
        if skeleton != AUTO:
            skeleton_joints(skeleton)
        self.source = source
        self.skeleton = skeleton
        self.detector = detector
        self.fitness = KeypointTerm(weight, loss, scale)
        self.use_for_start = bool(use_for_start)

    def open(self, sequence, foreground) -> KeypointStream | None:
        """The keypoints of ``sequence`` whose masks ``foreground`` makes, or None for
        silhouettes only; the choice and its reason are logged."""
        chosen, why = self.choose(sequence, foreground)
        log.info("keypoints: %s (%s)", chosen, why)
        if chosen == "none":
            return None
        if chosen == "files":
            files = sequence.keypoint_files(self.skeleton)
            return KeypointStream(chosen, SkeletonMap.of(files.skeleton), self.fitness, sequence, files=files)
        if chosen == "detector" and self.detector == SEGMENTATION_DETECTOR and foreground.finds_landmarks:
            return KeypointStream("segmentation", SkeletonMap.of("MEDIAPIPE_33"), self.fitness, sequence)
        detector = registry.make_detector(self.detector)
        return KeypointStream(chosen, SkeletonMap.of(detector.skeleton), self.fitness, sequence, detector=detector)

    def choose(self, sequence, foreground) -> tuple[str, str]:
        """(``files``, ``detector`` or ``none``, why) for this sequence."""
        has_files = sequence.has_keypoints
        if self.source == "none":
            return "none", "keypoints.source=none: silhouettes only"
        if self.source == "files":
            if not has_files:
                raise ConfigError(
                    f"keypoints.source=files, but {sequence.root} has no keypoint files (pose/<camera>_json/ or "
                    "keypoints.csv): add them, or set keypoints.source=auto"
                )
            return "files", "keypoints.source=files"
        if self.source == "detector":
            return "detector", f"keypoints.source=detector: {self.detector}"
        if has_files:
            return "files", "the sequence has keypoint files"
        if foreground.finds_landmarks:
            return "detector", "person segmentation finds MediaPipe's landmarks"
        return "none", "no keypoint files and no detector run: silhouettes only"


class KeypointStream:
    """One sequence's keypoints frame by frame, mapped onto the model's points, in the ideal
    pin-hole cameras of the masks.

    Args:
        method: where they come from: ``files``, ``segmentation`` (the foreground's
            landmarks) or ``detector``.
        skeleton_map: the detector's skeleton and its mapping.
        fitness: the keypoint term every frame's keypoints carry.
        sequence: the sequence (its ``cameras``, with their lenses, and ``images``).
        files: the sequence's keypoint files (``files``).
        detector: the detector plugin (``detector``).
    """

    def __init__(
        self, method: str, skeleton_map: SkeletonMap, fitness: KeypointTerm, sequence, files=None, detector=None
    ):
        self.method = method
        self.map = skeleton_map
        self.fitness = fitness
        self.sequence = sequence
        self.files = files
        self.detector = detector
        self.seen = np.zeros(len(skeleton_map.points), np.int64)  # frames x cameras each point was confident in
        self.counted: set[int] = set()  # the frames counted in seen (the start reads frame 0 too)

    def frame(self, frame: int, landmarks: list | None = None) -> Keypoints:
        """The keypoints of ``frame``; ``landmarks`` are the foreground's (C entries of
        (33, 3) ideal-camera px and visibility, or None) for ``segmentation``."""
        cameras = self.sequence.cameras
        if self.method == "segmentation":
            joints = len(skeleton_joints(self.map.skeleton))
            raw = np.stack([np.zeros((joints, 3)) if p is None else np.asarray(p, np.float64) for p in landmarks or []])
            ideal = raw  # the foreground's landmarks are in the ideal cameras already
        elif self.method == "files":
            ideal = self.files.ideal_frame(frame, cameras)
        else:
            ideal = np.stack([np.asarray(self.detector(image), np.float64) for image in self.sequence.images(frame)])
            ideal[..., :2] = np.stack([cam.ideal_pixels(points[:, :2]) for cam, points in zip(cameras, ideal)])
        observed = ideal[:, self.map.rows]
        observed[observed[..., 2] <= 0] = 0.0
        if frame not in self.counted:
            self.counted.add(frame)
            self.seen += np.count_nonzero(observed[..., 2] > 0, axis=0)
        return Keypoints(self.map.points, self.map.offsets_mm, observed, self.fitness)

    def summary(self) -> dict:
        """What ``summary.json`` records: the source, skeleton, term and how often each
        model point was seen (share of frames x cameras)."""
        cameras = max(1, len(self.sequence.cameras) * len(self.counted))
        return {
            "source": self.method,
            "skeleton": self.map.skeleton,
            "weight": self.fitness.weight,
            "loss": self.fitness.loss,
            "scale": self.fitness.scale,
            "seen": {point: round(float(n) / cameras, 4) for point, n in zip(self.map.points, self.seen)},
        }
