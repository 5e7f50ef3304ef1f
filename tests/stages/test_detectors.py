"""The built-in MediaPipe detector keeps the detector contract (the conformance suite)."""

from mmocap.testing.detectors import DetectorConformance


class TestMediaPipeDetector(DetectorConformance):
    name = "mediapipe"
