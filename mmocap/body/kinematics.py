"""Forward kinematics of the 16-joint skeleton, batched over poses.

Each joint j has a rest position ``o_j`` (mm, model coordinates with the root at the
origin) and a rest frame ``A_j`` (3x3, columns = the joint's local axes in model
coordinates).  Its local rotation is ``L_j = A_j Rx(a) Ry(b) Rz(c) A_j^T``; the global
transform is ``G_j = G_parent @ [L_j | o_j - o_parent]`` and the root's is
``[L_root | T]`` with ``T`` the root translation.  The *skinning* transform
``S_j = G_j @ translate(-o_j)`` maps a rest-pose point attached to joint j to its posed
world position (both in mm).
"""
from __future__ import annotations

import numpy as np

from mmocap.body.skeleton import JOINTS, PARENT_INDEX


def euler_xyz(angles: np.ndarray) -> np.ndarray:
    """(..., 3) angles (a, b, c) in rad -> (..., 3, 3) ``Rx(a) @ Ry(b) @ Rz(c)``."""
    ca, cb, cc = np.cos(angles[..., 0]), np.cos(angles[..., 1]), np.cos(angles[..., 2])
    sa, sb, sc = np.sin(angles[..., 0]), np.sin(angles[..., 1]), np.sin(angles[..., 2])
    R = np.empty(angles.shape[:-1] + (3, 3))
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


def global_transforms(poses: np.ndarray, rest_positions: np.ndarray,
                      rest_frames: np.ndarray) -> np.ndarray:
    """Joint-to-world transforms.

    Args:
        poses: (n, 51) full pose vectors (mm, rad).
        rest_positions: (J, 3) joint rest positions in mm, root at the origin.
        rest_frames: (J, 3, 3) rest frames A_j.
    Returns:
        (n, J, 4, 4) global transforms G_j.
    """
    poses = np.atleast_2d(np.asarray(poses, dtype=np.float64))
    n, J = poses.shape[0], len(JOINTS)
    parents = PARENT_INDEX
    # local transforms [L_j | o_j - o_parent], the root's [L_root | T]
    local = np.zeros((n, J, 4, 4))
    local[..., 3, 3] = 1.0
    local[..., :3, :3] = (rest_frames @ euler_xyz(poses[:, 3:].reshape(n, J, 3))
                          @ np.swapaxes(rest_frames, -1, -2))
    local[..., :3, 3] = np.where((parents >= 0)[:, None],
                                 rest_positions - rest_positions[np.maximum(parents, 0)], 0.0)
    local[:, parents < 0, :3, 3] = poses[:, :3]
    G = np.empty_like(local)
    for j, p in enumerate(parents):  # parents come before their children
        G[:, j] = local[:, j] if p < 0 else G[:, p] @ local[:, j]
    return G


def skinning_transforms(global_T: np.ndarray, rest_positions: np.ndarray) -> np.ndarray:
    """(n, J, 4, 4) G_j -> (n, J, 4, 4) S_j = G_j @ translate(-o_j)."""
    S = global_T.copy()
    S[..., :3, 3] -= np.einsum("njab,jb->nja", global_T[..., :3, :3], rest_positions)
    return S
