"""2-D keypoint files: OpenPose-style JSON per camera and frame (Pose2Sim's layout).

Pose2Sim, OpenPose, RTMPose/rtmlib, AlphaPose and others write one JSON file per frame and
camera, ``pose/<camera>_json/<camera>_<frame:06d>.json``, holding ``people``, each with its
``pose_keypoints_2d``: ``x, y, confidence`` for every joint of the detector's skeleton
(:mod:`mmocap.data.skeletons`), in pixels of the raw (distorted) image.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mmocap.io import write_json_atomic

#: the folder of a recording (or synthetic sequence) that holds the keypoint files
POSE_FOLDER = "pose"


def openpose_path(root: Path, camera: str, frame: int) -> Path:
    """Where Pose2Sim writes camera ``camera``'s keypoints of ``frame`` under ``root``."""
    return Path(root) / POSE_FOLDER / f"{camera}_json" / f"{camera}_{frame:06d}.json"


def write_openpose_json(path: Path, people: list[np.ndarray]) -> None:
    """Write one frame's detections as an OpenPose JSON file.

    Args:
        path: the file to write (its folder is made).
        people: one (J, 3) array per person: x, y in px and the confidence in [0, 1]; a
            joint not found is written as 0, 0, 0, as OpenPose does.
    """
    entries = []
    for person in people:
        person = np.asarray(person, np.float64)
        values = np.where(np.isfinite(person), person, 0.0)
        values[person[:, 2] <= 0] = 0.0
        entries.append({"person_id": [-1], "pose_keypoints_2d": [round(float(v), 3) for v in values.ravel()]})
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, {"version": 1.3, "people": entries})
