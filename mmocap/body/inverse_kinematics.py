"""Inverse kinematics: the pose whose body-model markers best match measured marker positions
(:func:`fit_pose`), such as a first frame's motion-capture markers."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from mmocap.body.model import BodyModel
from mmocap.errors import DataError

# Markers on the rigid torso, aligned first by fit_pose.
TORSO_MARKERS = ("head", "neck", "pelvis", "l_shoulder", "r_shoulder", "l_hip", "r_hip")
# Pull of every joint angle towards the rest pose in fit_pose: residual mm per rad.
REST_PULL_MM_PER_RAD = 20.0


def _rigid_fit(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R and translation t minimising |R source + t - target| over (N, 3) points."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    U, _, Vt = np.linalg.svd((source - cs).T @ (target - ct))
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return R, ct - R @ cs


def _euler_of(R: np.ndarray) -> np.ndarray:
    """Angles (a, b, c) in rad with ``Rx(a) @ Ry(b) @ Rz(c) = R``."""
    return np.array([np.arctan2(-R[1, 2], R[2, 2]), np.arcsin(np.clip(R[0, 2], -1, 1)), np.arctan2(-R[0, 1], R[0, 0])])


def fit_pose(body: BodyModel, target: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The pose (51,) whose model markers best match ``target`` (15, 3) mm (NaN = missing).

    Aligns the rest pose's torso markers rigidly to the target's, then solves bounded least
    squares over the ``mask`` entries within the joint limits, each joint angle pulled
    towards the rest pose by :data:`REST_PULL_MM_PER_RAD`.
    """
    present = ~np.isnan(target).any(axis=1)
    anchors = present & np.isin(body.marker_names, TORSO_MARKERS)
    if anchors.sum() < 3:
        raise DataError(f"{anchors.sum()} torso markers present, at least 3 are needed to fit x0")
    x = np.zeros(len(mask))
    R, t = _rigid_fit(body.markers(x[None])[0][anchors], target[anchors])
    x[:3], x[3:6] = t, _euler_of(R)
    free = mask & (body.lower < body.upper)
    angle = free.copy()
    angle[:6] = False

    def residual(v):
        x[free] = v
        return np.r_[(body.markers(x[None])[0] - target)[present].ravel(), REST_PULL_MM_PER_RAD * x[angle]]

    start = np.clip(x[free], body.lower[free], body.upper[free])
    result = least_squares(residual, start, bounds=(body.lower[free], body.upper[free]), x_scale="jac")
    x[free] = result.x
    return x
