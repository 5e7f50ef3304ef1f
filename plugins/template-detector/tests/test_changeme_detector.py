# TEMPLATE: rename the name changeme-coco and this file (test file names must be unique across plugins).
"""The detector keeps mmocap's detector contract (the conformance suite)."""

from mmocap.testing.detectors import DetectorConformance


class TestChangemeCocoDetector(DetectorConformance):
    name = "changeme-coco"
