"""Forward kinematics of the 16-joint skeleton, batched over poses.

Each joint j has a rest position ``o_j`` (mm, model coordinates with the root at the
origin) and a rest frame ``A_j`` (3x3, columns = the joint's local axes in model
coordinates).  Its local rotation is ``L_j = A_j Rx(a) Ry(b) Rz(c) A_j^T``; the global
transform is ``G_j = G_parent @ [L_j | o_j - o_parent]`` and the root's is
``[L_root | T]`` with ``T`` the root translation.  The *skinning* transform
``S_j = G_j @ translate(-o_j)`` maps a rest-pose point attached to joint j to its posed
world position (both in mm).

Arithmetic. Everything is float64 with each operation rounded (no fused multiply-add) in
the order written here, so that a backend may compute the transforms itself and get the
same bits (the OpenCL evaluator does, from :meth:`KinematicChain.pose_rows` and
:meth:`KinematicChain.rows`):

- ``cos`` and ``sin`` of the angles are NumPy's (:func:`joint_trig`);
- ``Rx(a) Ry(b) Rz(c)`` as :func:`euler_xyz` writes its entries;
- a 3x3 product ``P Q`` has entries ``(P[i,0] Q[0,k] + P[i,1] Q[1,k]) + P[i,2] Q[2,k]`` and a
  matrix-vector product ``P v`` entries ``(P[i,0] v0 + P[i,1] v1) + P[i,2] v2``;
- ``L_j = A_j (R A_j^T)``; ``G_j`` has rotation ``R_parent L_j`` and translation
  ``R_parent (o_j - o_parent) + t_parent`` (``o_j - o_parent`` rounded once);
- ``S_j`` has rotation ``R_j`` and translation ``t_j - R_j o_j``.
"""

from __future__ import annotations

import numpy as np

from mmocap.body.skeleton import PARENT_INDEX


def _depth_levels() -> list[np.ndarray]:
    """The joints below the root by depth in the tree: each level's parents are in earlier ones."""
    depth = np.zeros(len(PARENT_INDEX), dtype=int)
    for j, p in enumerate(PARENT_INDEX):  # parents come before their children
        depth[j] = 0 if p < 0 else depth[p] + 1
    return [np.flatnonzero(depth == d) for d in range(1, depth.max() + 1)]


_LEVELS = _depth_levels()
_ROOT = int(np.flatnonzero(PARENT_INDEX < 0)[0])


def parent_offsets(rest_positions: np.ndarray) -> np.ndarray:
    """(J, 3) ``o_j - o_parent`` (mm), each rounded once; 0 for the root."""
    offsets = rest_positions - rest_positions[np.maximum(PARENT_INDEX, 0)]
    offsets[_ROOT] = 0.0
    return offsets


def _product(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """(..., 3, 3) ``P Q`` in the module's order."""
    return (P[..., :, 0, None] * Q[..., None, 0, :] + P[..., :, 1, None] * Q[..., None, 1, :]) + P[..., :, 2, None] * Q[
        ..., None, 2, :
    ]


def _apply(P: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(..., 3, 3) and (..., 3) -> (..., 3) ``P v`` in the module's order."""
    return (P[..., :, 0] * v[..., None, 0] + P[..., :, 1] * v[..., None, 1]) + P[..., :, 2] * v[..., None, 2]


def _euler(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(..., 3) cosines and sines of (a, b, c) -> (..., 3, 3) ``Rx(a) @ Ry(b) @ Rz(c)``."""
    ca, cb, cc = c[..., 0], c[..., 1], c[..., 2]
    sa, sb, sc = s[..., 0], s[..., 1], s[..., 2]
    R = np.empty(c.shape[:-1] + (3, 3))
    R[..., 0, 0] = cb * cc
    R[..., 0, 1] = -cb * sc
    R[..., 0, 2] = sb
    R[..., 1, 0] = ca * sc + sa * sb * cc
    R[..., 1, 1] = ca * cc - sa * sb * sc
    R[..., 1, 2] = -sa * cb
    R[..., 2, 0] = sa * sc - ca * sb * cc
    R[..., 2, 1] = sa * cc + ca * sb * sc
    R[..., 2, 2] = ca * cb
    return R


def euler_xyz(angles: np.ndarray) -> np.ndarray:
    """(..., 3) angles (a, b, c) in rad -> (..., 3, 3) ``Rx(a) @ Ry(b) @ Rz(c)``."""
    angles = np.ascontiguousarray(angles, dtype=np.float64)
    return _euler(np.cos(angles), np.sin(angles))


def joint_trig(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, 51) poses -> cosines and sines (n, 16, 3) of each joint's angles (a, b, c)."""
    angles = np.ascontiguousarray(poses[:, 3:]).reshape(len(poses), len(PARENT_INDEX), 3)
    return np.cos(angles), np.sin(angles)


def global_transforms(poses: np.ndarray, rest_positions: np.ndarray, rest_frames: np.ndarray) -> np.ndarray:
    """Joint-to-world transforms.

    Args:
        poses: (n, 51) full pose vectors (mm, rad).
        rest_positions: (J, 3) joint rest positions in mm, root at the origin.
        rest_frames: (J, 3, 3) rest frames A_j.

    Returns:
        (n, J, 4, 4) global transforms G_j.
    """
    poses = np.atleast_2d(np.asarray(poses, dtype=np.float64))
    rest_positions = np.asarray(rest_positions, dtype=np.float64)
    rest_frames = np.asarray(rest_frames, dtype=np.float64)
    n, J = poses.shape[0], len(PARENT_INDEX)
    c, s = joint_trig(poses)
    L = _product(rest_frames, _product(_euler(c, s), np.swapaxes(rest_frames, -1, -2)))
    offsets = parent_offsets(rest_positions)
    rotation, translation = np.empty((n, J, 3, 3)), np.empty((n, J, 3))
    rotation[:, _ROOT] = L[:, _ROOT]
    translation[:, _ROOT] = poses[:, :3]
    for level in _LEVELS:
        parent_rotation = rotation[:, PARENT_INDEX[level]]
        rotation[:, level] = _product(parent_rotation, L[:, level])
        translation[:, level] = _apply(parent_rotation, offsets[level]) + translation[:, PARENT_INDEX[level]]
    G = np.zeros((n, J, 4, 4))
    G[..., :3, :3] = rotation
    G[..., :3, 3] = translation
    G[..., 3, 3] = 1.0
    return G


def skinning_transforms(global_T: np.ndarray, rest_positions: np.ndarray) -> np.ndarray:
    """(n, J, 4, 4) G_j -> (n, J, 4, 4) S_j = G_j @ translate(-o_j)."""
    S = global_T.copy()
    S[..., :3, 3] = global_T[..., :3, 3] - _apply(global_T[..., :3, :3], np.asarray(rest_positions, dtype=np.float64))
    return S


class KinematicChain:
    """A body's skeleton with the inputs a backend needs to compute its transforms.

    Args:
        rest_positions: (16, 3) joint rest positions o_j, mm.
        rest_frames: (16, 3, 3) rest frames A_j.

    :meth:`transforms` is ``skinning_transforms(global_transforms(...))``; computed from
    :meth:`pose_rows` and :meth:`rows` in the module's order, it gives the same bits.
    """

    def __init__(self, rest_positions: np.ndarray, rest_frames: np.ndarray):
        self.rest_positions = np.asarray(rest_positions, dtype=np.float64)
        self.rest_frames = np.asarray(rest_frames, dtype=np.float64)

    def transforms(self, poses: np.ndarray) -> np.ndarray:
        """(n, 51) poses -> (n, 16, 4, 4) skinning transforms S_j (rest mm -> world mm)."""
        return skinning_transforms(global_transforms(poses, self.rest_positions, self.rest_frames), self.rest_positions)

    def pose_rows(self, poses: np.ndarray) -> np.ndarray:
        """(n, 51) poses -> (n, 3 + 6 J) float64: the root translation T (mm), then per joint
        cos a, cos b, cos c, sin a, sin b, sin c (:func:`joint_trig`)."""
        poses = np.atleast_2d(np.asarray(poses, dtype=np.float64))
        c, s = joint_trig(poses)
        trig = np.concatenate([c, s], axis=2).reshape(len(poses), -1)
        return np.concatenate([poses[:, :3], trig], axis=1)

    def rows(self) -> np.ndarray:
        """(J, 16) float64 per joint: A_j (3x3 row-major), o_j - o_parent (3, mm, 0 for the
        root), o_j (3, mm) and the parent's index (-1 for the root)."""
        return np.c_[
            self.rest_frames.reshape(-1, 9),
            parent_offsets(self.rest_positions),
            self.rest_positions,
            PARENT_INDEX.astype(np.float64),
        ]
