"""The model's keypoints: the points of the body that 2-D keypoint detectors find.

A *model point* is one of the 16 joint centres of :data:`mmocap.body.skeleton.JOINTS` or
``Nose``, the foremost point of the head (the mesh vertex of the neck's segment, in its
upper half, furthest forward, +z). Each rides rigidly on one joint, like the markers: its
world position is ``T_j [p; 1]`` with ``T_j = body.transforms(X)[:, j]`` and ``p`` its rest
position (mm). A detector's joint may sit elsewhere than the model's point (a hip landmark
lies in front of the hip's centre): that *definition offset* is added to ``p`` in the rest
frame (mm) by whoever maps a detector's skeleton onto the model
(:mod:`mmocap.data.skeletons`).
"""

from __future__ import annotations

import numpy as np

from mmocap.body.skeleton import JOINTS
from mmocap.errors import ConfigError

#: every point a detector's joint may be mapped onto: the joint centres, then the nose
MODEL_POINTS = (*JOINTS, "Nose")

_NECK = JOINTS.index("Neck")


def nose_rest_mm(mesh) -> np.ndarray:
    """(3,) rest position (mm) of the nose tip: the foremost (+z) vertex of the neck's
    segment among those above the middle of the head (``mesh.vertices`` (N, 3) mm,
    ``mesh.vertex_joint`` (N,), ``mesh.pivots`` (16, 3) mm)."""
    vertices = np.asarray(mesh.vertices, np.float64)
    head = np.asarray(mesh.vertex_joint) == _NECK
    neck_y = float(mesh.pivots[_NECK][1])
    top = vertices[head, 1].max()
    upper = vertices[head & (vertices[:, 1] > neck_y + 0.5 * (top - neck_y))]
    return upper[np.argmax(upper[:, 2])]


def model_points(body, names, offsets_mm=None) -> tuple[np.ndarray, np.ndarray]:
    """The joints and rest positions of the named model points.

    Args:
        body (BodyModel): ``joint_rest_positions`` (16, 3) mm and ``mesh`` (for the nose).
        names: K names from :data:`MODEL_POINTS`.
        offsets_mm: (K, 3) definition offsets added in the rest frame, mm; None for none.

    Returns:
        joint: (K,) int, the joint each point rides on; rest: (K, 3) float64 mm.
    """
    joint = np.empty(len(names), np.int64)
    rest = np.empty((len(names), 3))
    for k, name in enumerate(names):
        if name not in MODEL_POINTS:
            raise ConfigError(f"unknown model point {name!r}; known: {', '.join(MODEL_POINTS)}")
        if name == "Nose":
            joint[k], rest[k] = _NECK, nose_rest_mm(body.mesh)
        else:
            joint[k] = JOINTS.index(name)
            rest[k] = body.joint_rest_positions[joint[k]]
    if offsets_mm is not None:
        rest += np.asarray(offsets_mm, np.float64).reshape(len(names), 3)
    return joint, rest


def posed_points(body, X: np.ndarray, joint: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """(n, 51) poses -> (n, K, 3) world positions (mm) of the points ``joint`` (K,) and
    ``rest`` (K, 3) mm of :func:`model_points`."""
    S = body.transforms(np.asarray(X, np.float64))[:, joint]
    return np.einsum("nkab,kb->nka", S[..., :3, :3], rest) + S[..., :3, 3]
