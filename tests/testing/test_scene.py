"""The synthetic benchmark scene (mmocap.testing.scene): its foreground is the reference pose's
own silhouettes, and its candidates scatter the active joint angles around that pose."""

import numpy as np

from mmocap import registry
from mmocap.testing.scene import Scene


def test_the_foreground_is_the_reference_pose_and_the_candidates_move_its_active_joints_only():
    scene = Scene(1000, cameras=2)
    assert len(scene.cameras) == len(scene.foreground) == 2
    assert scene.foreground[0].shape == (480, 640)
    with registry.make_evaluator("numpy") as ev:
        ev.setup(scene.body, scene.cameras, scene.foreground)
        model, overlap = ev.counts(scene.pose[None])
    assert (model > 0).all()
    assert np.array_equal(model, overlap)
    X = scene.candidates(3)
    assert X.shape == (3, 51)
    assert not np.array_equal(X[0], X[1])
    moved = (X != scene.pose).any(axis=0)
    assert not moved[:6].any()
    assert not moved[~scene.body.mask.astype(bool)].any()
    np.testing.assert_array_equal(scene.candidates(3), X)  # the seed fixes them
