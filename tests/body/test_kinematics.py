import numpy as np
import pytest

from mmocap.body import skeleton
from mmocap.body.kinematics import euler_xyz, global_transforms, skinning_transforms
from mmocap.body.model import BodyModel
from mmocap.errors import ConfigError


@pytest.fixture(scope="module")
def body():
    return BodyModel("S1", dof=39)


def rot(axis, angle):
    c, s = np.cos(angle), np.sin(angle)
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def test_euler_order_matches_elementary_rotations():
    a, b, c = 0.3, -0.7, 1.1
    expected = rot("x", a) @ rot("y", b) @ rot("z", c)
    np.testing.assert_allclose(euler_xyz(np.array([a, b, c])), expected, atol=1e-12)


def test_dof_counts_follow_table_1():
    assert skeleton.dof_mask(39).sum() == 39
    assert skeleton.dof_mask(28).sum() == 28
    assert skeleton.dof_mask(51).sum() == 51
    names = np.array(skeleton.parameter_names())
    reduced = set(names[skeleton.dof_mask(39) & ~skeleton.dof_mask(28)])
    assert reduced == {
        "UpperSpine.rx",
        "UpperSpine.ry",
        "UpperSpine.rz",
        "LWrist.ry",
        "LWrist.rz",
        "RWrist.ry",
        "RWrist.rz",
        "LAnkle.rx",
        "LAnkle.ry",
        "RAnkle.rx",
        "RAnkle.ry",
    }
    assert set(names[skeleton.dof_mask(39)]) >= {"LElbow.ry", "LKnee.rx", "Root.tx"}
    assert "LElbow.rx" not in set(names[skeleton.dof_mask(39)])
    with pytest.raises(ConfigError, match="body.dof"):
        skeleton.dof_mask(30)


def test_identity_pose_gives_rest_positions(body):
    x = np.zeros(skeleton.N_FULL)
    G = body.global_transforms(x[None])[0]
    np.testing.assert_allclose(G[:, :3, 3], body.joint_rest_positions, atol=1e-9)
    S = body.transforms(x[None])[0]
    np.testing.assert_allclose(S, np.tile(np.eye(4), (16, 1, 1)), atol=1e-9)
    np.testing.assert_allclose(body.posed_vertices(x), body.rest_vertices, atol=1e-9)


def test_root_translation_moves_everything(body):
    x = np.zeros(skeleton.N_FULL)
    x[:3] = [100.0, 2000.0, -50.0]
    np.testing.assert_allclose(body.posed_vertices(x), body.rest_vertices + x[:3], atol=1e-9)


def test_composition_child_follows_parent(body):
    """Rotating the left hip moves knee and ankle rigidly about the hip; the right leg stays."""
    rng = np.random.default_rng(3)
    x = np.zeros(skeleton.N_FULL)
    x[skeleton.parameter_index("LHip.rx")] = -0.8
    x[skeleton.parameter_index("LHip.rz")] = 0.3
    G = body.global_transforms(x[None])[0]
    j = {n: i for i, n in enumerate(skeleton.JOINTS)}
    hip = body.joint_rest_positions[j["LHip"]]
    R = G[j["LHip"], :3, :3]
    for child in ("LKnee", "LAnkle"):
        expected = hip + R @ (body.joint_rest_positions[j[child]] - hip)
        np.testing.assert_allclose(G[j[child], :3, 3], expected, atol=1e-9)
    np.testing.assert_allclose(G[j["RAnkle"], :3, 3], body.joint_rest_positions[j["RAnkle"]], atol=1e-9)
    # global = parent global @ local, for random full poses
    X = rng.normal(0, 0.4, size=(3, skeleton.N_FULL))
    G = body.global_transforms(X)
    for j_idx, p in enumerate(skeleton.PARENT_INDEX):
        if p >= 0:
            local = np.linalg.inv(G[:, p]) @ G[:, j_idx]
            np.testing.assert_allclose(
                local[:, :3, 3],
                np.broadcast_to(body.joint_rest_positions[j_idx] - body.joint_rest_positions[p], (3, 3)),
                atol=1e-6,
            )
            np.testing.assert_allclose(np.linalg.det(G[:, j_idx, :3, :3]), 1.0, atol=1e-9)


def test_flexion_signs(body):
    """+Rx bends the knee backwards; +Ry brings the forearm forward on both sides."""
    j = {n: i for i, n in enumerate(skeleton.JOINTS)}
    for param, _joint, end, axis, sign in (
        ("LKnee.rx", "LKnee", "LAnkle", 2, -1),
        ("LElbow.ry", "LElbow", "LWrist", 2, +1),
        ("RElbow.ry", "RElbow", "RWrist", 2, +1),
        ("LHip.rx", "LHip", "LKnee", 2, +1),
    ):
        x = np.zeros(skeleton.N_FULL)
        before = body.joint_positions(x[None])[0, j[end], axis]
        x[skeleton.parameter_index(param)] = 0.5 if param != "LHip.rx" else -0.5
        after = body.joint_positions(x[None])[0, j[end], axis]
        assert sign * (after - before) > 20, param


def test_joint_limits_and_masks(body):
    x = np.full(skeleton.N_FULL, 5.0)
    clipped = body.clip(x[None])[0]
    assert clipped[skeleton.parameter_index("LKnee.rx")] == pytest.approx(2.6)
    assert clipped[skeleton.parameter_index("LElbow.rx")] == 0.0  # not a valid axis
    assert clipped[0] == 5.0  # translation is unbounded
    lower, upper = skeleton.limits()
    assert np.all(lower <= upper)
    # every axis that Table 1 does not list is pinned to 0
    pinned = ~skeleton.dof_mask(39)
    assert np.all(lower[pinned] == 0)
    assert np.all(upper[pinned] == 0)
    b28 = BodyModel("S1", dof=28)
    assert b28.mask.sum() == 28
    assert np.all(b28.mask <= body.mask)


def test_skinning_transform_definition():
    rng = np.random.default_rng(0)
    rest = rng.normal(0, 100, size=(16, 3))
    frames = np.tile(np.eye(3), (16, 1, 1))
    X = rng.normal(0, 0.3, size=(2, 51))
    G = global_transforms(X, rest, frames)
    S = skinning_transforms(G, rest)
    # S_j maps the joint's own rest position to its posed position
    posed = np.einsum("njab,jb->nja", S[..., :3, :3], rest) + S[..., :3, 3]
    np.testing.assert_allclose(posed, G[..., :3, 3], atol=1e-9)


def test_kinematic_chain_is_the_bodys_transforms_and_describes_its_inputs(body):
    from mmocap.body.kinematics import KinematicChain

    rng = np.random.default_rng(2)
    X = rng.normal(0, 0.4, size=(5, skeleton.N_FULL))
    X[:, :3] = rng.normal(0, 500, (5, 3))
    chain = body.chain
    assert isinstance(chain, KinematicChain)
    np.testing.assert_array_equal(chain.transforms(X), body.transforms(X))
    # the same transforms from plain matrix products, A R A^T and the parent chain
    rest, frames = body.joint_rest_positions, body.rest_frames
    L = frames @ euler_xyz(X[:, 3:].reshape(5, 16, 3)) @ np.swapaxes(frames, -1, -2)
    G = np.zeros((5, 16, 4, 4))
    for j, p in enumerate(skeleton.PARENT_INDEX):
        local = np.tile(np.eye(4), (5, 1, 1))
        local[:, :3, :3] = L[:, j]
        local[:, :3, 3] = X[:, :3] if p < 0 else rest[j] - rest[p]
        G[:, j] = local if p < 0 else G[:, p] @ local
    np.testing.assert_allclose(chain.transforms(X), skinning_transforms(G, rest), atol=1e-9)
    # the device inputs: translation then cos, sin per joint; A, offset, rest position, parent
    rows = chain.pose_rows(X)
    assert rows.shape == (5, 3 + 6 * 16)
    np.testing.assert_array_equal(rows[:, :3], X[:, :3])
    np.testing.assert_array_equal(rows[:, 3 + 6 * 4 : 3 + 6 * 5], np.c_[np.cos(X[:, 15:18]), np.sin(X[:, 15:18])])
    table = chain.rows()
    assert table.shape == (16, 16)
    np.testing.assert_array_equal(table[:, 15], skeleton.PARENT_INDEX)
    np.testing.assert_array_equal(table[:, :9], frames.reshape(16, 9))
    np.testing.assert_array_equal(table[:, 12:15], rest)
    child = skeleton.JOINTS.index("LKnee")
    np.testing.assert_array_equal(table[child, 9:12], rest[child] - rest[skeleton.PARENT_INDEX[child]])
