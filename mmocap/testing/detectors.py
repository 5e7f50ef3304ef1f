"""Conformance suite for keypoint detector plugins (pytest).

Every detector registered under the ``mmocap.detectors`` entry points must pass it. A plugin
reuses it in one line of its own tests::

    from mmocap.testing.detectors import DetectorConformance

    class TestMyDetector(DetectorConformance):
        name = "mydetector"     # the entry-point name; ``params`` may set constructor args

The suite checks the contract of :class:`mmocap.api.Detector` that the keypoint stage
relies on, on a person rendered by mmocap's synthetic dataset (640x480, greyscale and
colour cameras): a known skeleton, one (J, 3) row per joint, confidences in [0, 1], the
same answer twice, the hips and shoulders found on the person's silhouette, and nothing
(all zeros) in an empty scene.
"""

from __future__ import annotations

import numpy as np
import pytest

from mmocap import registry
from mmocap.data.sequence import Sequence
from mmocap.data.skeletons import MAPPINGS, skeleton_joints
from mmocap.data.synthetic import generate
from mmocap.testing.scene import CONFORMANCE_SEQUENCE

#: the model points a detector must find on the rendered person (within NEAR_PX of its silhouette)
TORSO_POINTS = ("LShoulder", "RShoulder", "LHip", "RHip")
NEAR_PX = 3


class DetectorConformance:
    """Subclass with ``name`` (entry-point name) and optionally ``params`` (constructor
    arguments) to run the suite on one detector."""

    name: str = ""
    params: dict = {}

    @pytest.fixture(scope="class")
    def detector(self):
        reason = registry.unavailable("detector", self.name)
        if reason:
            pytest.skip(reason)
        return registry.make_detector(self.name, **self.params)

    @pytest.fixture(scope="class")
    def sequence(self, tmp_path_factory) -> Sequence:
        root = tmp_path_factory.mktemp("detector") / "S1_walking"
        return Sequence.open(generate(root, progress=False, **CONFORMANCE_SEQUENCE))

    def test_the_skeleton_is_known_and_mapped(self, detector):
        assert skeleton_joints(detector.skeleton)
        assert detector.skeleton in MAPPINGS

    def test_one_row_per_joint_with_confidences_in_0_1_and_the_same_twice(self, detector, sequence):
        joints = len(skeleton_joints(detector.skeleton))
        for image in sequence.images(1):
            found = np.asarray(detector(image))
            assert found.shape == (joints, 3)
            assert np.isfinite(found).all()
            assert ((found[:, 2] >= 0) & (found[:, 2] <= 1)).all()
            np.testing.assert_array_equal(found, detector(image))

    def test_the_torso_lies_on_the_rendered_person(self, detector, sequence):
        joints = skeleton_joints(detector.skeleton)
        rows = {point: joints.index(joint) for joint, (point, _) in MAPPINGS[detector.skeleton].items()}
        found_on_body = 0
        for cam, image in zip(sequence.cameras, sequence.images(1)):
            truth = sequence.silhouette(1, cam)
            found = np.asarray(detector(image))
            for point in TORSO_POINTS:
                u, v, confidence = found[rows[point]]
                if confidence <= 0:
                    continue
                near = truth[
                    max(int(v) - NEAR_PX, 0) : int(v) + NEAR_PX + 1, max(int(u) - NEAR_PX, 0) : int(u) + NEAR_PX + 1
                ]
                assert near.any(), f"{cam.name} {point} at ({u:.0f}, {v:.0f}) is off the person"
                found_on_body += 1
        assert found_on_body >= len(TORSO_POINTS) * len(sequence.cameras) // 2, "the torso was found in too few views"

    def test_an_empty_scene_gives_nothing(self, detector, sequence):
        found = np.asarray(detector(sequence.background(sequence.cameras[0])[0]))
        assert not found[:, 2].any()
