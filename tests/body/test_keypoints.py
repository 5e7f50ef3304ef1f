"""The model's keypoints: joint centres and the nose, posed rigidly with their joints."""

import numpy as np
import pytest

from mmocap.body.keypoints import MODEL_POINTS, model_points, nose_rest_mm, posed_points
from mmocap.body.model import BodyModel
from mmocap.body.skeleton import JOINTS
from mmocap.errors import ConfigError


@pytest.fixture(scope="module")
def body() -> BodyModel:
    return BodyModel(vertices=2000)


def test_the_joint_points_are_the_joint_centres_wherever_the_body_is_posed(body):
    rng = np.random.default_rng(0)
    X = body.clip(body.rest_pose() + rng.normal(0, 0.3, (4, 51)) * body.mask)
    joint, rest = model_points(body, JOINTS)
    np.testing.assert_allclose(posed_points(body, X, joint, rest), body.joint_positions(X), atol=1e-9)


def test_the_nose_is_in_front_of_the_neck_below_the_top_of_the_head(body):
    nose = nose_rest_mm(body.mesh)
    neck = body.joint_rest_positions[JOINTS.index("Neck")]
    top = body.mesh.vertices[:, 1].max()
    assert 60 < nose[2] - neck[2] < 200  # mm forward
    assert neck[1] + 80 < nose[1] < top - 60
    assert abs(nose[0]) < 15  # on the midline


def test_offsets_move_a_point_in_the_rest_frame_and_unknown_names_are_refused(body):
    _, plain = model_points(body, ("LHip",))
    _, moved = model_points(body, ("LHip",), [[0.0, 0.0, 30.0]])
    np.testing.assert_allclose(moved - plain, [[0.0, 0.0, 30.0]])
    assert len(MODEL_POINTS) == 17
    with pytest.raises(ConfigError, match="unknown model point 'Pelvis'"):
        model_points(body, ("Pelvis",))
