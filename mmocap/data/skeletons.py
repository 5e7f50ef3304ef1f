"""2-D keypoint skeletons of common detectors and their mapping onto the model's points.

A skeleton is the ordered list of joints a detector writes per person (OpenPose's
``pose_keypoints_2d`` triples, in this order). :data:`SKELETONS` holds those mmocap reads:

- ``HALPE_26``: RTMPose/AlphaPose's 26 joints, Pose2Sim's default;
- ``COCO_17``: the COCO keypoint challenge's 17 (MMPose, RTMPose, ViTPose, YOLO-pose);
- ``BODY_25``: OpenPose's default;
- ``MEDIAPIPE_33``: MediaPipe Pose / BlazePose's 33 landmarks (the person segmenter's).

:data:`MAPPINGS` says, per skeleton, which detector joint is which model point
(:data:`mmocap.body.keypoints.MODEL_POINTS`) and the definition offset (mm, in the
model's rest frame: x to the subject's left, y up, z forward) from the model point to
where that detector puts the joint. Detector joints with no model point (eyes, ears,
toes, heels, fingers) are left out. A detector's left is the person's left, as mmocap's.
The offsets and where each comes from are documented in ``docs/keypoints.md``.
"""

from __future__ import annotations

from mmocap.errors import ConfigError

COCO_17 = (
    "Nose", "LEye", "REye", "LEar", "REar", "LShoulder", "RShoulder", "LElbow", "RElbow",
    "LWrist", "RWrist", "LHip", "RHip", "LKnee", "RKnee", "LAnkle", "RAnkle",
)  # fmt: skip
HALPE_26 = (
    *COCO_17, "Head", "Neck", "Hip", "LBigToe", "RBigToe", "LSmallToe", "RSmallToe", "LHeel", "RHeel",
)  # fmt: skip
BODY_25 = (
    "Nose", "Neck", "RShoulder", "RElbow", "RWrist", "LShoulder", "LElbow", "LWrist", "MidHip",
    "RHip", "RKnee", "RAnkle", "LHip", "LKnee", "LAnkle", "REye", "LEye", "REar", "LEar",
    "LBigToe", "LSmallToe", "LHeel", "RBigToe", "RSmallToe", "RHeel",
)  # fmt: skip
MEDIAPIPE_33 = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye",
    "right_eye_outer", "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_pinky",
    "right_pinky", "left_index", "right_index", "left_thumb", "right_thumb", "left_hip",
    "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle", "left_heel",
    "right_heel", "left_foot_index", "right_foot_index",
)  # fmt: skip

SKELETONS = {"HALPE_26": HALPE_26, "COCO_17": COCO_17, "BODY_25": BODY_25, "MEDIAPIPE_33": MEDIAPIPE_33}

#: the limb joints every skeleton here names alike (model point = detector joint)
_LIMBS = (
    "LShoulder", "LElbow", "LWrist", "RShoulder", "RElbow", "RWrist",
    "LHip", "LKnee", "LAnkle", "RHip", "RKnee", "RAnkle",
)  # fmt: skip
_SAME = {j: (j, (0.0, 0.0, 0.0)) for j in _LIMBS}
_ORIGIN = (0.0, 0.0, 0.0)

#: skeleton -> {detector joint: (model point, definition offset (x, y, z) mm)}
MAPPINGS: dict[str, dict[str, tuple[str, tuple[float, float, float]]]] = {
    "COCO_17": {"Nose": ("Nose", _ORIGIN), **_SAME},
    "HALPE_26": {"Nose": ("Nose", _ORIGIN), "Neck": ("Neck", _ORIGIN), "Hip": ("Root", _ORIGIN), **_SAME},
    "BODY_25": {"Nose": ("Nose", _ORIGIN), "Neck": ("Neck", _ORIGIN), "MidHip": ("Root", _ORIGIN), **_SAME},
    # measured: the medians of `mmocap keypoint-offsets` (`make keypoint-offsets`) over every action
    # of S1, S2 and S3, 7 cameras at 640x480, 180 frames; docs/results/keypoint_offsets.md
    "MEDIAPIPE_33": {
        "nose": ("Nose", (0.0, -20.0, -24.0)),
        "left_shoulder": ("LShoulder", (0.0, -8.0, 21.0)),
        "left_elbow": ("LElbow", (-6.0, -4.0, 8.0)),
        "left_wrist": ("LWrist", (-6.0, -15.0, 9.0)),
        "right_shoulder": ("RShoulder", (12.0, -7.0, 13.0)),
        "right_elbow": ("RElbow", (8.0, -9.0, 31.0)),
        "right_wrist": ("RWrist", (6.0, -15.0, 11.0)),
        "left_hip": ("LHip", (-20.0, -9.0, 12.0)),
        "left_knee": ("LKnee", (-4.0, 18.0, -9.0)),
        "left_ankle": ("LAnkle", (-1.0, 20.0, 9.0)),
        "right_hip": ("RHip", (21.0, -16.0, 21.0)),
        "right_knee": ("RKnee", (7.0, 15.0, -9.0)),
        "right_ankle": ("RAnkle", (3.0, 21.0, 6.0)),
    },
}  # fmt: skip


def skeleton_joints(name: str) -> tuple[str, ...]:
    """The joint names, in the detector's order, of the skeleton ``name``; ConfigError for
    an unknown one."""
    try:
        return SKELETONS[name]
    except KeyError:
        raise ConfigError(f"unknown keypoint skeleton {name!r}; known: {', '.join(SKELETONS)}") from None


def check_mapping(skeleton: str, mapping: dict) -> None:
    """ConfigError unless ``mapping`` ({detector joint: (model point, offset)}) names joints
    of the skeleton and locates the pelvis: the root, or both hips."""
    joints = skeleton_joints(skeleton)
    unknown = sorted(set(mapping) - set(joints))
    if unknown:
        raise ConfigError(f"keypoint mapping of {skeleton}: {', '.join(unknown)} is not a joint of that skeleton")
    points = {point for point, _ in mapping.values()}
    if "Root" not in points and not {"LHip", "RHip"} <= points:
        raise ConfigError(
            f"keypoint mapping of {skeleton} leaves the root and the hips unmapped: map a joint onto Root, "
            "or onto both LHip and RHip"
        )
