import numpy as np
import pytest

from mmocap.body.mesh import (
    SUBJECTS,
    SubjectDimensions,
    fit_subject,
    load_makehuman,
    resample,
)
from mmocap.body.model import MARKER_NAMES, BodyModel
from mmocap.errors import ConfigError


def test_makehuman_mesh_is_a_closed_body():
    mesh = load_makehuman()
    assert mesh.vertices.shape == (13380, 3)
    assert mesh.trimesh().is_watertight
    np.testing.assert_allclose(mesh.weights.sum(axis=1), 1.0)
    assert mesh.trimesh().volume > 0  # outward winding
    # every joint owns skin
    assert np.all(np.bincount(mesh.vertex_joint, minlength=16) > 100)
    # left joints on +x, right on -x, head above pelvis
    assert mesh.pivots[3, 0] > 100
    assert mesh.pivots[6, 0] < -100
    assert mesh.pivots[9, 1] > 400


def test_subject_dimensions_differ():
    mesh = load_makehuman()
    heights = {}
    volumes = {}
    for name, dims in SUBJECTS.items():
        fitted = fit_subject(mesh, dims)
        heights[name] = np.ptp(fitted.vertices[:, 1])
        volumes[name] = fitted.trimesh().volume / dims.height_mm**3
        assert heights[name] == pytest.approx(dims.height_mm, rel=1e-6)
    assert len(set(np.round(list(heights.values())))) == 3
    assert volumes["S2"] > volumes["S1"] * 1.1 > volumes["S3"] * 1.1  # girth 1.12 vs 1 vs 0.9
    with pytest.raises(ConfigError, match="height_mm"):
        SubjectDimensions("X", 50.0)


@pytest.mark.parametrize("count", [13695, 27393])
def test_resampling_gives_exact_even_counts(count):
    mesh = fit_subject(load_makehuman(), SUBJECTS["S1"])
    samples = resample(mesh, count)
    assert samples.points.shape == (count, 3)
    np.testing.assert_allclose(np.linalg.norm(samples.normals, axis=1), 1.0)
    assert np.all(np.diff(samples.joint) >= 0)  # sorted by joint
    # evenness: nearest-neighbour distances are far more uniform than the raw mesh's
    from scipy.spatial import cKDTree

    d, _ = cKDTree(samples.points).query(samples.points, k=2)
    spacing = d[:, 1]
    assert spacing.std() / spacing.mean() < 0.35
    # normals point away from the body axis on the trunk
    trunk = samples.joint == 1
    radial = samples.points[trunk] - samples.points[trunk].mean(axis=0)
    radial[:, 1] = 0
    assert np.mean(np.sum(radial * samples.normals[trunk], axis=1) > 0) > 0.9


def test_body_model_markers_on_skin():
    body = BodyModel("S2")
    assert len(MARKER_NAMES) == body.marker_rest.shape[0] == 15
    m = body.markers(body.rest_pose()[None])[0]
    assert m[MARKER_NAMES.index("head"), 1] == pytest.approx(1720.0, abs=1.0)  # top of head, S2
    assert np.all(m[:, 1] > 0)  # above the floor
    with pytest.raises(ConfigError, match="unknown subject"):
        BodyModel("S9")


@pytest.mark.parametrize(("height_mm", "girth"), [(1000, 0.6), (2300, 1.6), (2300, 0.6), (1000, 1.6)])
def test_every_height_and_girth_allowed_builds_a_body_with_its_markers(height_mm, girth):
    body = BodyModel("S1", vertices=1000, height_mm=height_mm, girth=girth)
    markers = body.markers(body.rest_pose()[None])[0]
    assert np.ptp(markers[:, 1]) > 0.6 * height_mm  # head to ankles
    assert body.subject.height_mm == height_mm
    assert body.subject.girth == girth
