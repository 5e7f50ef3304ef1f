# TEMPLATE: rename this folder (the package changeme_detector) and describe your detector.
"""mmocap keypoint detector plugin (template): COCO_17 keypoints from MediaPipe Pose
(``keypoints.detector=changeme-coco``)."""
