"""Synthetic camera images: a cluttered static background and a shaded triangle mesh.

Conventions: world points in millimetres, y up; cameras as in :mod:`mmocap.camera`.
Colour images are (H, W, 3) uint8 in OpenCV's BGR order, greyscale ones (H, W) uint8;
input face colours are RGB in [0, 1].  Pixel centres follow OpenCV: the centre of pixel
(col, row) is at (col, row).

The mesh is rasterised with a NumPy z-buffer: vertices are projected with lens
distortion (triangles are small, so straight edges between distorted vertices are
accurate), snapped to 1/16 pixel like ``cv2.fillConvexPoly(..., shift=4)``, and a pixel
belongs to a triangle when its centre is inside it, with the top-left rule on edges.
That rule is watertight (a closed mesh leaves no cracks) and unbiased (a polygon covers
about its exact area).  Back faces (seen from the camera) are culled for the image and
each pixel shows the nearest front face by interpolated depth, which unlike a painter's
sort by mean depth also resolves interpenetrating limbs; the silhouette is the union of
all projected triangles, front and back, under the same rule.

The sensor model: the scene is multiplied by the light's gain of the frame (flicker),
converted to grey for a greyscale camera, and recorded with read and shot noise. The person
casts a soft shadow on the floor plane (:func:`floor_shadow`), which darkens the background
but not the person.
"""

from __future__ import annotations

import cv2
import numpy as np

from mmocap.camera import Camera

SUBPIXEL = 16  # vertex snapping grid: 1/16 pixel, as cv2's shift=4
MIN_DEPTH_MM = 1.0  # triangles with a vertex closer than this (or behind) are dropped
MAX_PIXEL = 2.0**24  # projected coordinates are clipped to this, keeping int64 exact
SHADE_JITTER = 0.03  # relative standard deviation of the per-face shade jitter
CHUNK = 1 << 22  # candidate pixels rasterised at once
LIGHT_DIR = (0.3, -1.0, 0.5)  # world direction the key light travels (y up: from above)

# RGB in [0, 1]: skin, hair and clothing tones for clutter that resembles a person.
_BODY_LIKE = np.array(
    [
        [0.87, 0.67, 0.55],
        [0.70, 0.52, 0.42],
        [0.55, 0.38, 0.30],
        [0.93, 0.78, 0.68],
        [0.15, 0.12, 0.10],
        [0.20, 0.22, 0.35],
        [0.12, 0.14, 0.20],
        [0.55, 0.20, 0.18],
        [0.25, 0.40, 0.60],
        [0.60, 0.60, 0.55],
        [0.30, 0.45, 0.25],
        [0.75, 0.70, 0.35],
    ]
)


def make_background(camera: Camera, rng: np.random.Generator) -> np.ndarray:
    """A textured, cluttered static scene for ``camera``: (H, W, 3) uint8 BGR.

    Walls above a random horizon and a floor below, with smooth colour variation, wall
    corners, floor seams, furniture, posters, round objects and cables (some in skin and
    clothing tones) and fine texture.  Deterministic for a given ``rng`` state.
    """
    h, w = camera.height, camera.width
    horizon = int(h * rng.uniform(0.4, 0.6))
    base = np.empty((h, w, 3), np.float32)
    base[:horizon] = rng.uniform(110, 210, 3)
    base[horizon:] = rng.uniform(50, 150, 3)
    for x in np.sort(rng.integers(0, w, rng.integers(1, 3))):  # wall corners
        base[:horizon, x:] *= rng.uniform(0.8, 1.15, 3).astype(np.float32)
    base += cv2.resize(rng.normal(0, 15, (5, 7, 3)).astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
    img = np.clip(base, 0, 255).astype(np.uint8)

    def colour():
        if rng.random() < 0.4:
            rgb = _BODY_LIKE[rng.integers(len(_BODY_LIKE))] * rng.uniform(0.8, 1.1)
        else:
            rgb = rng.uniform(0.05, 0.95, 3)
        return tuple(float(c) for c in np.clip(rgb[::-1] * 255, 0, 255))

    def point(y_lo, y_hi):
        return int(rng.integers(0, w)), int(rng.integers(y_lo, max(y_lo + 1, y_hi)))

    vx, vy = rng.uniform(0, w), horizon - rng.uniform(h / 4, h)
    seam = colour()
    for x in np.linspace(-w, 2 * w, rng.integers(6, 12)):  # floor seams
        top = vx + (x - vx) * (horizon - vy) / (2 * h - vy)
        cv2.line(img, (int(top), horizon), (int(x), 2 * h), seam, 1, cv2.LINE_AA)
    for _ in range(rng.integers(4, 9)):  # posters, shelves
        x, y = point(0, horizon)
        pw, ph = (int(s) for s in rng.uniform(0.04, 0.2, 2) * (w, h))
        cv2.rectangle(img, (x, y), (x + pw, y + ph), colour(), -1, cv2.LINE_AA)
        if rng.random() < 0.5:
            cv2.rectangle(img, (x, y), (x + pw, y + ph), colour(), int(rng.integers(1, 4)))
    for _ in range(rng.integers(3, 7)):  # furniture
        x, y = point(horizon - h // 6, h)
        fw, fh = (int(s) for s in rng.uniform(0.06, 0.25, 2) * (w, h))
        cv2.rectangle(img, (x, y - fh), (x + fw, y), colour(), -1, cv2.LINE_AA)
        cv2.rectangle(img, (x, y - fh), (x + fw, y - fh + max(2, fh // 8)), colour(), -1)
    for _ in range(rng.integers(3, 8)):  # lamps, plants, balls
        centre = point(0, h)
        axes = tuple(int(a) for a in rng.uniform(0.01, 0.08, 2) * w)
        cv2.ellipse(img, centre, axes, float(rng.uniform(0, 180)), 0, 360, colour(), -1, cv2.LINE_AA)
    for _ in range(rng.integers(3, 8)):  # cables
        pts = np.stack([rng.integers(0, w, 3), rng.integers(horizon, h, 3)], axis=1)
        cv2.polylines(img, [pts.astype(np.int32)], False, colour(), int(rng.integers(1, 4)), cv2.LINE_AA)

    texture: np.ndarray = cv2.resize(
        rng.normal(0, 5, (h // 4 + 1, w // 4 + 1, 3)).astype(np.float32), (w, h), interpolation=cv2.INTER_LINEAR
    )
    texture += rng.standard_normal((h, w, 3), dtype=np.float32) * 3
    texture += img
    texture += 0.5
    return np.clip(texture, 0, 255).astype(np.uint8)


def _add_noise(image: np.ndarray, rng: np.random.Generator, sigma: float, shot_noise: float = 0.0) -> np.ndarray:
    """Image (grey levels, any dtype) plus sensor noise, rounded and clipped to uint8.

    The noise is Gaussian with variance ``sigma**2 + shot_noise * I`` at grey level ``I``:
    read noise plus photon shot noise, whose variance grows with the signal.
    """
    noisy = np.asarray(image, dtype=np.float32)
    if sigma > 0 or shot_noise > 0:
        std = np.sqrt(sigma * sigma + shot_noise * np.maximum(noisy, 0), dtype=np.float32)
        noisy = noisy + rng.standard_normal(noisy.shape, dtype=np.float32) * std
    return np.clip(noisy + 0.5, 0, 255).astype(np.uint8)


def _sensor_image(
    image: np.ndarray,
    camera: Camera,
    rng: np.random.Generator,
    noise_sigma: float,
    gain: float = 1.0,
    shot_noise: float = 0.0,
) -> np.ndarray:
    """BGR (H, W, 3) scene -> what the camera records: the scene times the light's ``gain``,
    greyscale if needed, then noise (see :func:`_add_noise`), uint8."""
    scene: np.ndarray = np.asarray(image, dtype=np.float32)
    if gain != 1.0:
        scene = scene * np.float32(gain)
    if not camera.colour:
        scene = cv2.cvtColor(np.clip(scene, 0, 255), cv2.COLOR_BGR2GRAY)
    return _add_noise(scene, rng, noise_sigma, shot_noise)


def noisy_background_frames(
    background: np.ndarray,
    camera: Camera,
    rng: np.random.Generator,
    n: int,
    noise_sigma: float,
    gains=None,
    shot_noise: float = 0.0,
) -> list[np.ndarray]:
    """``n`` recordings of the empty scene: (H, W, 3) BGR or (H, W) grey uint8 each.

    ``background`` is (H, W, 3) uint8 BGR; ``gains`` (n,) the light's gain in each frame
    (default 1); the sensor model is that of :func:`render_view`.
    """
    gains = np.ones(n) if gains is None else np.asarray(gains, dtype=np.float64)
    if gains.shape != (n,):
        raise ValueError(f"need {n} gains, got shape {gains.shape}")
    return [_sensor_image(background, camera, rng, noise_sigma, g, shot_noise) for g in gains]


def light_directions(light_dir, radius: float, samples: int) -> np.ndarray:
    """(samples, 3) unit directions spread over a disc of angular ``radius`` (rad) around
    ``light_dir``: the centre, then points on a ring at 0.7 radius (an area light)."""
    d = np.asarray(light_dir, dtype=np.float64)
    d = d / np.linalg.norm(d)
    if samples == 1 or radius == 0:
        return d[None]
    u = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    v = np.cross(d, u)
    angles = 2 * np.pi * np.arange(samples - 1) / (samples - 1)
    ring = d + np.tan(0.7 * radius) * (np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * v)
    dirs = np.vstack([d, ring])
    return dirs / np.linalg.norm(dirs, axis=1, keepdims=True)


def floor_shadow(
    camera: Camera,
    vertices_mm: np.ndarray,
    faces: np.ndarray,
    light_dir,
    strength: float,
    light_radius: float = 0.15,
    samples: int = 5,
    blur_px: float = 1.5,
) -> np.ndarray:
    """(H, W) float32 light factor of the floor, in [1 - strength, 1]: the soft shadow the
    mesh casts on the floor plane y = 0 from an area light (:func:`light_directions`).

    Each light sample's hard shadow (the mesh flattened onto the floor along the light and
    projected through the lens) is rasterised at half resolution; their mean, blurred by
    ``blur_px`` and resized to the image, gives a penumbra that widens with the height of
    the occluder above the floor. ``strength`` is the fraction of light the umbra loses.
    """
    h, w = camera.height, camera.width
    if strength <= 0:
        return np.ones((h, w), np.float32)
    vertices = np.asarray(vertices_mm, dtype=np.float64)
    height = np.maximum(vertices[:, 1:2], 0.0)
    hw, hh = (w + 1) // 2, (h + 1) // 2
    cover: np.ndarray = np.zeros(hh * hw, np.float32)
    dirs = light_directions(light_dir, light_radius, samples)
    for d in dirs:
        if d[1] >= 0:
            raise ValueError(f"light direction {d} does not point down (y up)")
        on_floor = vertices - height * (d / d[1])
        on_floor[:, 1] = 0.0
        uv = (camera.project(on_floor) + 0.5) / 2 - 0.5  # half-resolution pixels
        ok = np.isfinite(uv).all(axis=1) & (camera.to_camera(on_floor)[:, 2] > MIN_DEPTH_MM)
        tris = np.asarray(faces)[ok[faces].all(axis=1)]
        q = np.rint(np.clip(uv[tris], -MAX_PIXEL, MAX_PIXEL) * SUBPIXEL).astype(np.int64)
        hit = np.zeros(hh * hw, bool)
        for _, pix, _ in _fragments(q, hw, hh):
            hit[pix] = True
        cover += hit
    cover = cover.reshape(hh, hw) / len(dirs)
    if blur_px > 0:
        cover = cv2.GaussianBlur(cover, (0, 0), blur_px / 2)
    cover = cv2.resize(cover, (w, h), interpolation=cv2.INTER_LINEAR)
    return (1 - strength * cover).astype(np.float32)


def _fragments(q: np.ndarray, width: int, height: int):
    """Pixels covered by triangles with snapped vertices ``q`` (T, 3, 2) int64 (1/16 px).

    Yields per chunk ``(tri, pix, bary)``: (M,) triangle index, (M,) flat pixel index
    ``row * width + col`` and (M, 3) barycentric weights of the pixel centre.
    """
    a, b, c = q[:, 0], q[:, 1], q[:, 2]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    flip = area < 0  # orient all with positive area
    b, c = np.where(flip[:, None], c, b), np.where(flip[:, None], b, c)
    lo = -(-np.minimum(np.minimum(a, b), c) // SUBPIXEL)  # ceil: first pixel centre
    hi = np.maximum(np.maximum(a, b), c) // SUBPIXEL
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, [width - 1, height - 1])
    span = np.maximum(hi - lo + 1, 0)
    count = np.where(area != 0, span[:, 0] * span[:, 1], 0)
    ends = np.cumsum(count)
    starts = ends - count
    # Edges opposite a, b, c, each with its offset: 0 on top or left edges (a pixel
    # centre exactly on them is inside), 1 elsewhere.
    edges = []
    for p, r in ((b, c), (c, a), (a, b)):
        d = r - p
        top_left = (d[:, 1] < 0) | ((d[:, 1] == 0) & (d[:, 0] > 0))
        edges.append((p, d, np.where(top_left, 0, 1)))
    start = 0
    while start < len(q):
        stop = max(int(np.searchsorted(ends, starts[start] + CHUNK, side="right")), start + 1)
        tri = np.repeat(np.arange(start, stop), count[start:stop])
        local = np.arange(starts[start], ends[stop - 1]) - starts[tri]
        cols = lo[tri, 0] + local % span[tri, 0]
        rows = lo[tri, 1] + local // span[tri, 0]
        x, y = cols * SUBPIXEL, rows * SUBPIXEL
        weights = []
        inside = np.ones(len(tri), bool)
        for p, d, offset in edges:
            e = d[tri, 0] * (y - p[tri, 1]) - d[tri, 1] * (x - p[tri, 0])
            inside &= e >= offset[tri]
            weights.append(e)
        bary = np.stack(weights, axis=1)[inside] / np.abs(area[tri[inside], None])
        bary[flip[tri[inside]]] = bary[flip[tri[inside]]][:, [0, 2, 1]]
        yield tri[inside], rows[inside] * width + cols[inside], bary
        start = stop


def render_view(
    camera: Camera,
    vertices_mm: np.ndarray,
    faces: np.ndarray,
    face_colours: np.ndarray,
    background: np.ndarray,
    rng: np.random.Generator,
    light_dir=LIGHT_DIR,
    ambient: float = 0.35,
    noise_sigma: float = 2.0,
    shot_noise: float = 0.0,
    gain: float = 1.0,
    shadow: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Render a shaded triangle mesh over ``background`` as ``camera`` records it.

    Args:
        camera: the recording camera: intrinsics in px, pose in mm, image size and distortion.
        vertices_mm: (N, 3) world points in mm.
        faces: (F, 3) int triangles, counter-clockwise seen from outside.
        face_colours: (F, 3) RGB albedo in [0, 1].
        background: (H, W, 3) uint8 BGR scene (:func:`make_background`).
        rng: source of the per-face shade jitter and the sensor noise.
        light_dir: world direction the light travels (y up: the default comes from above).
        ambient: shade of faces turned away from the light; lit faces get
            ``ambient + (1 - ambient) * cos(angle)``.
        noise_sigma: Gaussian read noise in 8-bit units, added after the greyscale
            conversion of a greyscale camera.
        shot_noise: shot noise, variance per grey level (see :func:`_add_noise`).
        gain: the light's intensity this frame (lighting flicker), multiplies the scene.
        shadow: (H, W) light factor of the background (:func:`floor_shadow`), None = 1.

    Returns:
        image: (H, W, 3) uint8 BGR for a colour camera, (H, W) uint8 for a greyscale one.
        silhouette: (H, W) bool, the union of all projected triangles, front and back.
    """
    h, w = camera.height, camera.width
    if background.shape != (h, w, 3):
        raise ValueError(f"background is {background.shape}, camera {camera.name} needs {(h, w, 3)}")
    vertices = np.asarray(vertices_mm, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    cam_pts = camera.to_camera(vertices)
    uv = camera.project(vertices)
    ok = (cam_pts[:, 2] > MIN_DEPTH_MM) & np.isfinite(uv).all(axis=1)
    kept = np.flatnonzero(ok[faces[:, 0]] & ok[faces[:, 1]] & ok[faces[:, 2]])
    faces = faces[kept]

    tri_cam = cam_pts[faces]  # (T, 3, 3)
    normal_cam = np.cross(tri_cam[:, 1] - tri_cam[:, 0], tri_cam[:, 2] - tri_cam[:, 0])
    front = np.einsum("ij,ij->i", normal_cam, tri_cam.mean(axis=1)) < 0
    tri_world = vertices[faces]
    normal = np.cross(tri_world[:, 1] - tri_world[:, 0], tri_world[:, 2] - tri_world[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    light = np.asarray(light_dir, dtype=np.float64)
    lambert = np.clip(-(normal @ (light / np.linalg.norm(light))), 0, None)
    shade = ambient + (1 - ambient) * lambert
    shade *= 1 + SHADE_JITTER * rng.standard_normal(len(faces))
    bgr = np.clip(np.asarray(face_colours, np.float64)[kept, ::-1] * shade[:, None] * 255 + 0.5, 0, 255).astype(
        np.uint8
    )

    q = np.rint(np.clip(uv[faces], -MAX_PIXEL, MAX_PIXEL) * SUBPIXEL).astype(np.int64)
    inv_depth = 1.0 / tri_cam[:, :, 2]
    silhouette = np.zeros(h * w, bool)
    zbuf = np.zeros(h * w)
    face_at = np.full(h * w, -1)
    for tri, pix, bary in _fragments(q, w, h):
        silhouette[pix] = True
        tri, pix, bary = tri[front[tri]], pix[front[tri]], bary[front[tri]]
        iz = np.einsum("ij,ij->i", bary, inv_depth[tri])  # 1/z is affine on the screen
        order = np.lexsort((-iz, pix))
        first = order[np.diff(pix[order], prepend=-1) != 0]  # nearest per pixel
        nearer = iz[first] > zbuf[pix[first]]
        zbuf[pix[first[nearer]]] = iz[first[nearer]]
        face_at[pix[first[nearer]]] = tri[first[nearer]]

    image = np.array(background, dtype=np.float32)
    if shadow is not None:
        image *= shadow[:, :, None]
    image = image.reshape(h * w, 3)
    drawn = np.flatnonzero(face_at >= 0)
    image[drawn] = bgr[face_at[drawn]]
    image = _sensor_image(image.reshape(h, w, 3), camera, rng, noise_sigma, gain, shot_noise)
    return image, silhouette.reshape(h, w)
