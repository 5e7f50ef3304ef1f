"""Inverse kinematics: a pose found from its markers alone."""

import numpy as np

from mmocap.body.inverse_kinematics import fit_pose
from mmocap.body.model import BodyModel
from mmocap.body.skeleton import dof_mask
from mmocap.stages.accuracy import marker_error


def test_fit_pose_recovers_a_turned_pose():
    """A pose turned about the vertical and bent is found from its markers alone."""
    body = BodyModel("S1", vertices=None)
    mask = dof_mask(39)
    x = np.zeros(51)
    x[:3] = (300.0, 950.0, -200.0)
    x[4] = 2.5  # root turned about y
    x[3 + 3 * 11] = 0.6  # left knee flexed
    x[3 + 3 * 4 + 1] = 1.0  # left elbow flexed
    fitted = fit_pose(body, body.markers(x[None])[0], mask)
    assert marker_error(body.markers(fitted[None]), body.markers(x[None]))[0] < 5.0
