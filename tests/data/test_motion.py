"""The synthetic motions: each action's poses, turned about the vertical axis on request."""

import numpy as np

from mmocap.data.motion import generate_motion


def test_a_turned_motion_is_the_same_motion_turned_about_the_vertical_axis():
    plain = generate_motion("boxing", 8, 60.0, 950.0, seed=4)
    turned = generate_motion("boxing", 8, 60.0, 950.0, seed=4, turn_deg=180.0)
    np.testing.assert_allclose(turned[:, [0, 2]], -plain[:, [0, 2]], atol=1e-9)  # half a turn: x, z negated
    np.testing.assert_allclose(turned[:, 4], plain[:, 4] + np.pi)  # Root.ry: facing the other way
    np.testing.assert_array_equal(turned[:, 5:], plain[:, 5:])  # the body's own motion unchanged
    np.testing.assert_array_equal(generate_motion("boxing", 8, 60.0, 950.0, seed=4, turn_deg=0.0), plain)
