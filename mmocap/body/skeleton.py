"""The 16-joint skeleton and its pose parameterisation (Yeguas et al. 2014, Table 1).

A *full pose vector* has 51 entries: the root translation ``Tx, Ty, Tz`` in mm (the world
position of the root joint), then ``Rx, Ry, Rz`` in radians for each of the 16 joints in
the order of :data:`JOINTS`.  Each joint's rotation is ``Rx(a) @ Ry(b) @ Rz(c)`` expressed
in the joint's rest frame (see :mod:`mmocap.body.kinematics`).  A body model with 39 or 28
degrees of freedom keeps only the axes of Table 1; the others stay at 0.

Model axes: x to the subject's left, y up, z forward; the rest pose is MakeHuman's A-pose.
"""

from __future__ import annotations

import numpy as np

from mmocap.errors import ConfigError

JOINTS = (
    "Root",
    "BottomSpine",
    "UpperSpine",
    "LShoulder",
    "LElbow",
    "LWrist",
    "RShoulder",
    "RElbow",
    "RWrist",
    "Neck",
    "LHip",
    "LKnee",
    "LAnkle",
    "RHip",
    "RKnee",
    "RAnkle",
)
PARENTS = {
    "Root": None,
    "BottomSpine": "Root",
    "UpperSpine": "BottomSpine",
    "LShoulder": "UpperSpine",
    "LElbow": "LShoulder",
    "LWrist": "LElbow",
    "RShoulder": "UpperSpine",
    "RElbow": "RShoulder",
    "RWrist": "RElbow",
    "Neck": "UpperSpine",
    "LHip": "Root",
    "LKnee": "LHip",
    "LAnkle": "LKnee",
    "RHip": "Root",
    "RKnee": "RHip",
    "RAnkle": "RKnee",
}
PARENT_INDEX = np.array([-1 if PARENTS[j] is None else JOINTS.index(PARENTS[j]) for j in JOINTS])

# Table 1: valid rotation axes per joint; '*' joints lose theirs in the 28-DOF reduction.
ROTATION_AXES = {
    "Root": "xyz",
    "BottomSpine": "xyz",
    "UpperSpine": "xyz",
    "LShoulder": "xyz",
    "LElbow": "y",
    "LWrist": "yz",
    "RShoulder": "xyz",
    "RElbow": "y",
    "RWrist": "yz",
    "Neck": "xyz",
    "LHip": "xyz",
    "LKnee": "x",
    "LAnkle": "xy",
    "RHip": "xyz",
    "RKnee": "x",
    "RAnkle": "xy",
}
REDUCED_AWAY = ("UpperSpine", "LWrist", "RWrist", "LAnkle", "RAnkle")

# Anatomical limits in radians for (Rx, Ry, Rz); signs follow the joint frames of
# mmocap.body.kinematics: knee flexion is +Rx, hip flexion -Rx, elbow flexion +Ry.  Zero is
# MakeHuman's rest pose, whose elbows are already flexed by about 45 degrees.
JOINT_LIMITS = {
    "Root": ((-np.inf, np.inf),) * 3,
    "BottomSpine": ((-0.6, 0.9), (-0.7, 0.7), (-0.5, 0.5)),
    "UpperSpine": ((-0.5, 0.6), (-0.6, 0.6), (-0.4, 0.4)),
    "LShoulder": ((-1.6, 1.6), (-1.2, 2.6), (-1.6, 1.8)),
    "LElbow": ((0, 0), (-0.9, 2.0), (0, 0)),
    "LWrist": ((0, 0), (-1.2, 1.2), (-0.9, 0.9)),
    "RShoulder": ((-1.6, 1.6), (-1.2, 2.6), (-1.8, 1.6)),
    "RElbow": ((0, 0), (-0.9, 2.0), (0, 0)),
    "RWrist": ((0, 0), (-1.2, 1.2), (-0.9, 0.9)),
    "Neck": ((-0.8, 0.9), (-1.2, 1.2), (-0.6, 0.6)),
    "LHip": ((-2.2, 0.6), (-0.9, 0.9), (-0.5, 1.2)),
    "LKnee": ((-0.1, 2.6), (0, 0), (0, 0)),
    "LAnkle": ((-0.9, 0.8), (-0.6, 0.6), (0, 0)),
    "RHip": ((-2.2, 0.6), (-0.9, 0.9), (-1.2, 0.5)),
    "RKnee": ((-0.1, 2.6), (0, 0), (0, 0)),
    "RAnkle": ((-0.9, 0.8), (-0.6, 0.6), (0, 0)),
}

N_FULL = 3 + 3 * len(JOINTS)
SUPPORTED_DOF = (28, 39, 51)


def parameter_names() -> list[str]:
    """Names of the 51 full-vector entries, e.g. ``'LKnee.rx'``."""
    names = ["Root.tx", "Root.ty", "Root.tz"]
    for joint in JOINTS:
        names += [f"{joint}.r{axis}" for axis in "xyz"]
    return names


def parameter_index(name: str) -> int:
    """Index of a parameter such as ``'RElbow.ry'`` in the full vector."""
    try:
        return parameter_names().index(name)
    except ValueError:
        raise ConfigError(f"unknown pose parameter '{name}'") from None


def dof_mask(dof: int) -> np.ndarray:
    """(51,) bool: which entries of the full vector a ``dof``-DOF model estimates."""
    if dof not in SUPPORTED_DOF:
        raise ConfigError(f"body.dof must be one of {SUPPORTED_DOF}, got {dof}")
    mask = np.zeros(N_FULL, bool)
    mask[:3] = True
    for j, joint in enumerate(JOINTS):
        if dof == 28 and joint in REDUCED_AWAY:
            continue
        for a, axis in enumerate("xyz"):
            mask[3 + 3 * j + a] = dof == 51 or axis in ROTATION_AXES[joint]
    assert mask.sum() == dof
    return mask


def limits() -> tuple[np.ndarray, np.ndarray]:
    """(51,) lower and upper bounds of the full vector (translation unbounded)."""
    lower = np.full(N_FULL, -np.inf)
    upper = np.full(N_FULL, np.inf)
    for j, joint in enumerate(JOINTS):
        for a, (lo, hi) in enumerate(JOINT_LIMITS[joint]):
            lower[3 + 3 * j + a], upper[3 + 3 * j + a] = lo, hi
    return lower, upper
