"""The silhouette rule against silhouettes the tracker did not draw: the generator's
rasterised triangles (mmocap.data.render) of the sequence's own body."""

import numpy as np
import pytest

from mmocap.bitmask import ForegroundMask
from mmocap.body.model import BodyModel
from mmocap.data.sequence import Sequence
from mmocap.evaluators.numpy_backend import NumpyEvaluator


@pytest.mark.parametrize("frame", [0, 3])
def test_the_true_body_fits_the_rendered_silhouettes_better_than_a_thinner_or_broader_one(tiny_sequence, frame):
    """Without the half-patch inset of the vertices the union of patches is the skin's
    silhouette dilated all round, and girth 0.9 scored better than the true 1.0."""
    sequence = Sequence.open(tiny_sequence)
    masks = [ForegroundMask(cam.undistort_mask(sequence.silhouette(frame, cam))) for cam in sequence.cameras]
    pose = np.load(tiny_sequence / "poses.npy")[frame]
    true_body = BodyModel(sequence.subject)
    fitness = {}
    with NumpyEvaluator() as evaluator:
        for girth in (0.9, 1.0, 1.1):
            body = true_body.reshaped(girth=girth)
            x = pose.copy()
            x[1] += body.floor_offset_mm - true_body.floor_offset_mm  # the feet stay on the floor
            evaluator.setup(body, sequence.cameras, masks)
            fitness[girth] = float(evaluator(x[None])[0])
    assert fitness[1.0] < min(fitness[0.9], fitness[1.1]), fitness
