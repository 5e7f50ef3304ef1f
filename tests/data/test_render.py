"""Rendering of the synthetic camera images (mmocap.data.render)."""

import cv2
import numpy as np
import pytest

from mmocap.camera import Camera
from mmocap.data import render

W, H, FOCAL = 640, 480, 600.0
GREY = 120


def camera(colour=True, dist=(0, 0, 0, 0, 0)) -> Camera:
    """Camera 4 m from the origin on +z, looking at it, y up."""
    return Camera.look_at("T", (0, 0, 4000), (0, 0, 0), FOCAL, W, H, dist, colour)


def flat_background(value=GREY) -> np.ndarray:
    return np.full((H, W, 3), value, np.uint8)


def signed_volume(vertices, faces) -> float:
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)


def cube(size=1000.0, rotation=None, centre=(0, 0, 0)):
    """(8, 3) vertices and (12, 3) faces, counter-clockwise seen from outside."""
    rotation = np.eye(3) if rotation is None else rotation
    v = (
        np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * size / 2
    ) @ rotation.T + centre
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    assert signed_volume(v - np.asarray(centre), faces) > 0  # outward winding
    return v, faces


def icosphere(radius=500.0, subdivisions=3):
    """Vertices and faces of a subdivided icosahedron, counter-clockwise seen from outside."""
    p = (1 + 5**0.5) / 2
    v = [
        (-1, p, 0),
        (1, p, 0),
        (-1, -p, 0),
        (1, -p, 0),
        (0, -1, p),
        (0, 1, p),
        (0, -1, -p),
        (0, 1, -p),
        (p, 0, -1),
        (p, 0, 1),
        (-p, 0, -1),
        (-p, 0, 1),
    ]
    f = [
        (0, 11, 5),
        (0, 5, 1),
        (0, 1, 7),
        (0, 7, 10),
        (0, 10, 11),
        (1, 5, 9),
        (5, 11, 4),
        (11, 10, 2),
        (10, 7, 6),
        (7, 1, 8),
        (3, 9, 4),
        (3, 4, 2),
        (3, 2, 6),
        (3, 6, 8),
        (3, 8, 9),
        (4, 9, 5),
        (2, 4, 11),
        (6, 2, 10),
        (8, 6, 7),
        (9, 8, 1),
    ]
    verts = [np.array(x, float) / np.linalg.norm(x) for x in v]
    faces = f
    for _ in range(subdivisions):
        mid, new = {}, []

        def midpoint(i, j, mid=mid):
            key = (min(i, j), max(i, j))
            if key not in mid:
                m = verts[i] + verts[j]
                verts.append(m / np.linalg.norm(m))
                mid[key] = len(verts) - 1
            return mid[key]

        for a, b, c in faces:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    verts, faces = np.array(verts) * radius, np.array(faces)
    assert signed_volume(verts, faces) > 0
    return verts, faces


def render_plain(cam, vertices, faces, colours=None, background=None, seed=0, **kw):
    colours = np.full((len(faces), 3), 0.8) if colours is None else colours
    background = flat_background() if background is None else background
    kw.setdefault("noise_sigma", 0.0)
    return render.render_view(cam, vertices, faces, colours, background, np.random.default_rng(seed), **kw)


def quad(z=0.0, half=400.0, towards_camera=True):
    """Square in the plane z, facing +z (the test camera) when ``towards_camera``."""
    v = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    return v, faces if towards_camera else faces[:, ::-1]


def hull_area(points) -> float:
    return float(cv2.contourArea(cv2.convexHull(points.astype(np.float32))))


@pytest.mark.parametrize("rotation", [np.eye(3), cv2.Rodrigues(np.array([0.4, 0.7, -0.2]))[0]])
def test_cube_silhouette_area_matches_projection(rotation):
    cam = camera()
    v, f = cube(rotation=rotation)
    _, sil = render_plain(cam, v, f)
    expected = hull_area(cam.project(v))  # a convex body projects to the hull
    if np.allclose(rotation, np.eye(3)):
        assert expected == pytest.approx((FOCAL * 1000 / 3500) ** 2, rel=1e-6)
    assert sil.sum() == pytest.approx(expected, rel=0.02)


def test_closed_sphere_has_no_cracks_and_matches_area():
    cam = camera()
    v, f = icosphere()
    _, sil = render_plain(cam, v, f)
    filled = np.zeros((H, W), np.uint8)
    contours, _ = cv2.findContours(sil.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    cv2.drawContours(filled, contours, -1, 1, -1)
    assert len(contours) == 1
    assert np.array_equal(filled.astype(bool), sil)
    assert sil.sum() == pytest.approx(hull_area(cam.project(v)), rel=0.02)


def test_silhouette_agrees_with_cv2_project_points_under_distortion():
    dist = np.array([-0.25, 0.12, 1e-3, -1e-3, 0.0])
    cam = camera(dist=dist)
    v, f = icosphere()
    v = v + (1200, 700, 0)  # off-axis, where distortion is strong
    _, sil = render_plain(cam, v, f)
    rvec, _ = cv2.Rodrigues(cam.R)
    uv = cv2.projectPoints(v, rvec, cam.t, cam.K, cam.dist)[0].reshape(-1, 2)
    near = cv2.dilate(sil.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    px = np.rint(uv).astype(int)
    assert near[px[:, 1], px[:, 0]].all()
    hull = np.zeros((H, W), np.uint8)
    cv2.fillConvexPoly(hull, np.rint(cv2.convexHull(uv.astype(np.float32)) * 16).astype(np.int32), 1, cv2.LINE_8, 4)
    iou = (sil & hull.astype(bool)).sum() / (sil | hull.astype(bool)).sum()
    assert iou > 0.97


def test_back_faces_are_culled_but_in_the_silhouette():
    cam = camera()
    background = flat_background()
    v, f = quad(towards_camera=True)
    image, sil = render_plain(cam, v, f, background=background)
    assert (image != background).any(axis=2).sum() == sil.sum() > 0
    v, f = quad(towards_camera=False)
    image, sil_back = render_plain(cam, v, f, background=background)
    assert np.array_equal(image, background)
    assert np.array_equal(sil_back, sil)


def test_nearest_cube_face_is_visible():
    """The cube's face towards the camera shows, whatever the face order (culling sign, depth)."""
    cam = camera()
    v, f = cube(rotation=cv2.Rodrigues(np.array([0.0, 0.3, 0.0]))[0])
    colours = np.repeat(np.vstack([np.eye(3), 1 - np.eye(3)]), 2, axis=0) * 0.9 + 0.05
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    towards = cam.centre - v[f].mean(axis=1)
    nearest = int(
        np.argmax(
            np.einsum("ij,ij->i", normals, towards) / np.linalg.norm(normals, axis=1) / np.linalg.norm(towards, axis=1)
        )
    )
    for order in (np.arange(12), np.arange(12)[::-1]):
        image, _ = render_plain(cam, v, f[order], colours[order], ambient=1.0)
        centre = image[H // 2, W // 2].astype(float)
        expected = colours[nearest][::-1] * 255
        assert np.abs(centre - expected).max() < 0.15 * 255


def test_inverted_cube_shows_its_inside():
    cam = camera()
    v, f = cube(rotation=cv2.Rodrigues(np.array([0.2, 0.5, 0.0]))[0])
    outside, sil = render_plain(cam, v, f)
    inside, sil_inv = render_plain(cam, v, f[:, ::-1])
    assert np.array_equal(sil, sil_inv)
    assert np.abs(outside[sil].astype(int) - inside[sil]).mean() > 10


def test_lambertian_shading():
    cam = camera()
    v, f = quad()  # normal +z, towards the camera
    albedo = np.array([0.8, 0.6, 0.4])
    light = np.array([0.0, -1.0, -1.0])  # from above and the camera's side
    image, sil = render_plain(cam, v, f, np.tile(albedo, (2, 1)), light_dir=light, ambient=0.3)
    cos = 1 / np.sqrt(2)
    expected = albedo[::-1] * (0.3 + 0.7 * cos) * 255
    assert np.abs(image[sil].mean(axis=0) - expected).max() < 0.06 * 255
    dark, _ = render_plain(cam, v, f, np.tile(albedo, (2, 1)), light_dir=-light, ambient=0.3)
    assert np.abs(dark[sil].mean(axis=0) - albedo[::-1] * 0.3 * 255).max() < 0.06 * 255


def test_nearer_surface_wins():
    cam = camera()
    far, f = quad(z=-500, half=600)
    near, _ = quad(z=500, half=200)
    v = np.vstack([far, near])
    faces = np.vstack([f, f + 4])
    colours = np.array([[1, 0, 0], [1, 0, 0], [0, 0, 1], [0, 0, 1.0]])
    for order in ([0, 1, 2, 3], [2, 3, 0, 1]):
        image, _ = render_plain(cam, v, faces[order], colours[order], ambient=1.0)
        b, g, r = image[H // 2, W // 2].astype(int)
        assert b > 200
        assert r < 50


def test_greyscale_camera_gives_2d_image():
    v, f = cube()
    image, sil = render_plain(camera(colour=False), v, f, noise_sigma=2.0)
    assert image.shape == (H, W)
    assert image.dtype == np.uint8
    assert sil.shape == (H, W)
    assert sil.dtype == bool


@pytest.mark.parametrize("colour", [True, False])
def test_noise_standard_deviation(colour):
    cam = camera(colour=colour)
    v, f = cube(centre=(0, 0, 8000))  # behind the camera: only the background
    image, sil = render_plain(cam, v, f, noise_sigma=5.0)
    assert not sil.any()
    assert image.astype(float).std() == pytest.approx(5.0, rel=0.05)
    assert image.astype(float).mean() == pytest.approx(GREY, abs=0.1)
    frames = render.noisy_background_frames(flat_background(), cam, np.random.default_rng(1), 3, 5.0)
    assert len(frames) == 3
    assert frames[0].shape == image.shape
    assert not np.array_equal(frames[0], frames[1])
    assert np.std(np.stack(frames).astype(float)) == pytest.approx(5.0, rel=0.05)


def test_objects_behind_or_through_the_camera_draw_nothing():
    cam = camera()
    background = flat_background()
    v, f = cube(centre=(0, 0, 6000))
    image, sil = render_plain(cam, v, f, background=background)
    assert not sil.any()
    assert np.array_equal(image, background)
    v = np.array([[-300.0, 0, 3000], [300, 0, 3000], [0, 300, 4500]])  # one vertex behind
    f = np.array([[0, 1, 2]])
    image, sil = render_plain(cam, v, f, background=background)
    assert not sil.any()
    assert np.array_equal(image, background)


def test_image_outside_the_silhouette_is_the_background():
    cam = camera()
    background = render.make_background(cam, np.random.default_rng(5))
    v, f = icosphere()
    image, sil = render_plain(cam, v, f, background=background)
    assert np.array_equal(image[~sil], background[~sil])
    assert (image[sil] != background[sil]).any(axis=1).mean() > 0.9


def test_rendering_is_deterministic():
    cam = camera()
    v, f = icosphere(subdivisions=2)
    colours = np.random.default_rng(0).uniform(0, 1, (len(f), 3))
    bg1 = render.make_background(cam, np.random.default_rng(7))
    bg2 = render.make_background(cam, np.random.default_rng(7))
    assert np.array_equal(bg1, bg2)
    a = render_plain(cam, v, f, colours, bg1, seed=3, noise_sigma=2.0)
    b = render_plain(cam, v, f, colours, bg2, seed=3, noise_sigma=2.0)
    assert np.array_equal(a[0], b[0])
    assert np.array_equal(a[1], b[1])


def test_background_is_cluttered_colour_scene():
    bg = render.make_background(camera(colour=False), np.random.default_rng(11))
    assert bg.shape == (H, W, 3)
    assert bg.dtype == np.uint8
    assert bg.std() > 15
    assert len(np.unique(bg.reshape(-1, 3) // 32, axis=0)) > 20
    other = render.make_background(camera(), np.random.default_rng(12))
    assert np.abs(bg.astype(int) - other).mean() > 10


def test_rasterising_in_chunks_changes_nothing(monkeypatch):
    cam = camera(dist=(-0.2, 0.1, 0, 0, 0))
    v, f = icosphere(subdivisions=2)
    v = np.vstack([v, cube(size=1500, centre=(0, 0, -1500))[0]])
    f = np.vstack([f, cube()[1] + len(v) - 8])
    colours = np.random.default_rng(0).uniform(0, 1, (len(f), 3))
    whole = render_plain(cam, v, f, colours)
    monkeypatch.setattr(render, "CHUNK", 500)
    chunked = render_plain(cam, v, f, colours)
    assert np.array_equal(whole[0], chunked[0])
    assert np.array_equal(whole[1], chunked[1])


def floor_camera() -> Camera:
    """Camera 3 m up and 4 m back, looking at the floor origin (y up)."""
    return Camera.look_at("F", (0, 3000, 4000), (0, 0, 0), FOCAL, W, H)


def test_floor_shadow_is_soft_and_bounded_by_its_strength():
    cam = floor_camera()
    v, f = cube(size=600, centre=(0, 300, 0))  # a box standing on the floor
    hard = render.floor_shadow(cam, v, f, render.LIGHT_DIR, 0.4, light_radius=0.0, blur_px=0)
    soft = render.floor_shadow(cam, v, f, render.LIGHT_DIR, 0.4, light_radius=0.2)
    for light in (hard, soft):
        assert light.shape == (H, W)
        assert light.dtype == np.float32
        assert light.min() == pytest.approx(0.6, abs=1e-6)
        assert light.max() == 1.0
    umbra = hard < 0.7
    assert umbra.sum() > 1000
    # the light travels towards +z, the camera: the shadow lies below the box in the image
    centre_row = np.argwhere(umbra)[:, 0].mean()
    box_row = cam.project(np.array([[0.0, 0, 0]]))[0, 1]
    assert centre_row > box_row
    penumbra = lambda light: np.count_nonzero((light > 0.62) & (light < 0.98))  # noqa: E731
    assert penumbra(soft) > 2 * penumbra(hard)
    np.testing.assert_array_equal(render.floor_shadow(cam, v, f, render.LIGHT_DIR, 0.0), 1.0)


def test_shadow_darkens_the_background_not_the_person():
    cam = floor_camera()
    v, f = cube(size=600, centre=(0, 300, 0))
    light = render.floor_shadow(cam, v, f, render.LIGHT_DIR, 0.5, light_radius=0.0, blur_px=0)
    image, sil = render_plain(cam, v, f, shadow=light)
    plain, _ = render_plain(cam, v, f)
    assert ((light < 0.75) & ~sil).sum() > 500
    np.testing.assert_allclose(image[~sil].astype(float), GREY * light[~sil, None].repeat(3, 1), atol=0.51)
    assert np.array_equal(image[sil], plain[sil])


def test_light_directions_spread_over_the_area_light():
    dirs = render.light_directions(render.LIGHT_DIR, 0.2, 5)
    centre = np.asarray(render.LIGHT_DIR) / np.linalg.norm(render.LIGHT_DIR)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0)
    np.testing.assert_allclose(dirs[0], centre)
    np.testing.assert_allclose(np.arccos(dirs[1:] @ centre), 0.14, rtol=1e-6)
    assert render.light_directions(render.LIGHT_DIR, 0.0, 5).shape == (1, 3)


@pytest.mark.parametrize("colour", [True, False])
def test_gain_and_shot_noise(colour):
    cam = camera(colour=colour)
    v, f = cube(centre=(0, 0, 8000))  # behind the camera: only the background
    image, _ = render_plain(cam, v, f, gain=1.1)
    np.testing.assert_array_equal(image, round(GREY * 1.1))
    image, _ = render_plain(cam, v, f, noise_sigma=0.0, shot_noise=0.1)
    assert image.astype(float).std() == pytest.approx(np.sqrt(0.1 * GREY), rel=0.05)
    frames = render.noisy_background_frames(flat_background(), cam, np.random.default_rng(1), 2, 0.0, gains=[0.9, 1.2])
    assert [int(fr.mean()) for fr in frames] == [round(GREY * 0.9), round(GREY * 1.2)]
