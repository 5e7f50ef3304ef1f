"""The silhouette fitness that every evaluator backend computes (Cano Eq. 3-7, Yeguas Eq. 4-5).

This docstring is the specification; every backend (naive, numpy, multiprocessing,
OpenCL, ...) implements exactly this rule and must give the same pixel counts.

Inputs: a batch of poses ``X`` (n, P), a body (see :class:`SilhouetteEvaluator`), cameras
used as ideal pin-holes (``K``, ``R``, ``t`` in mm; lens distortion is ignored because the
foreground masks are undistorted upstream) and one foreground mask ``F_c`` (H_c, W_c) per
camera. Pixel centres are at integer coordinates, as in OpenCV.

For every candidate ``i``, camera ``c`` and joint ``j``:

1. ``M = E_c T_j`` (4x4), with ``E_c = camera.extrinsic`` and ``T_j = body.transforms(X)[i, j]``.
2. Patch side in pixels: ``z_j = (M [p_j; 1]).z`` with ``p_j = body.joint_rest_positions[j]``;
   ``s = max(1, ceil(f * body.patch_mm[j] * patch_scale / z_j))`` with ``f = camera.focal``,
   at most ``MAX_SIDE``. If ``z_j <= NEAR_MM`` the joint's vertices are all dropped. This is
   Cano Eq. 4 with one size per body part: ``body.patch_mm`` is its ``l_r`` (the side of a
   square of the mean triangle's area) and ``z_j`` its distance ``d``; the paper prints
   ``p = f d / l_r``, but the pin-hole model it invokes gives ``f l_r / d``, which is used.
3. Each vertex of joint ``j``, with rest position ``v`` (the skin vertex moved inward by half
   the patch side, :func:`vertex_table`) and unit normal ``n``, is kept iff its
   depth ``p.z`` (``p = M [v; 1]``, camera frame, mm) exceeds ``NEAR_MM`` and its normal
   faces the camera, ``n' . p < 0`` with ``n' = R n`` for ``M = [R t]`` (back-face culling).
4. Projection: ``u = (K[0] . p) / p.z``, ``v = (K[1] . p) / p.z``; centre pixel
   ``(cx, cy) = (floor(u + 0.5), floor(v + 0.5))``.

   Steps 1-2 and the coefficients of steps 3-4 are computed in float64 by
   :func:`view_geometry`, exactly as it spells them out (each operation rounded, no fused
   multiply-add), so that a backend may compute them itself (the OpenCL kernel does):
   ``A = [K[0] M; K[1] M; M[2]]`` (3x4 with entries ``aRC``) as ``P_c [R_j t_j]`` with
   ``P_c = [K[0] E; K[1] E; E[2]]`` (:func:`camera_rows`) and ``T_j = [R_j t_j]``, and the
   culling offset ``b = R^T t = R_j^T (t_j - o_c)`` for ``M = [R t]`` and the camera centre
   ``o_c``; ``A`` and ``b`` are then rounded to float32 once.

   Steps 3-4 are evaluated in float32, exactly as follows, so that every backend gets the
   same bits (float32 is what makes the OpenCL kernel fast on CPUs and GPUs alike). The
   inputs are :func:`vertex_table` (per vertex ``x, y, z, nx, ny, nz, nv``, with ``nv = n . v``)
   and the float32 coefficients ``A`` and ``b``. Then, in IEEE single precision, each
   operation rounded, no fused multiply-add, sums left to right::

       facing = nv + (nx * b0 + ny * b1 + nz * b2) < 0        # n' . p = n . v + n . b
       depth = a20 * x + a21 * y + a22 * z + a23                # kept iff facing, depth > NEAR_MM
       r = 1 / depth
       cx = floor((a00 * x + a01 * y + a02 * z + a03) * r + 0.5)
       cy = floor((a10 * x + a11 * y + a12 * z + a13) * r + 0.5)

   :func:`project` is this rule vectorised; the naive backend spells it out per vertex.
5. The patch covers columns ``cx - (s-1)//2 .. cx + s//2`` and rows ``cy - (s-1)//2 .. cy + s//2``,
   clipped to the image; a vertex outside the image can still cover border pixels.
6. The model silhouette ``M_c`` is the union of the patches; the counts are ``|M_c|`` and
   ``|M_c & F_c|``; ``|F_c|`` is fixed per frame.

Fitness per view (Eq. 6): ``f_c = (|M|-|M&F|) / (2|M|) + (|F|-|M&F|) / (2|F|)``; a term whose
denominator is 0 counts 0.5 (no overlap), except that a view with ``|M| = |F| = 0`` scores 0
(perfect match). The fitness of a candidate is the mean of ``f_c`` over the cameras (Eq. 7),
in [0, 1]; never NaN.

Steps 1-4 leave no freedom: the counts of every backend are equal, bit for bit.

Every backend exposes the per-view counts through :meth:`SilhouetteEvaluator.counts`
(``|M_c|`` and ``|M_c & F_c|``, (n, C) int64) besides the fitness, and one view's
silhouette through :meth:`SilhouetteEvaluator.render`; the conformance suite
:mod:`mmocap.testing.evaluators` holds every installed backend to naive's counts.
"""

from __future__ import annotations

from typing import Any, Self

import numpy as np
from threadpoolctl import threadpool_limits

from mmocap.body.keypoints import model_points
from mmocap.errors import ConfigError, DataError
from mmocap.evaluators.keypoint_term import Keypoints, person_height_px

NEAR_MM = 1.0
MAX_SIDE = 2**30  # patch sides are capped here (far beyond any image)


def camera_rows(cameras) -> np.ndarray:
    """(C, 16) float64 per camera, the inputs of steps 1-2 that depend on it alone:
    ``P = [K[0] E; K[1] E; E[2]]`` (3x4 row-major, ``E`` the extrinsic's top 3x4 rows, mm ->
    px, px, mm), the camera centre ``o`` (3, world mm) and the focal length ``f`` (px)."""
    rows = np.zeros((len(cameras), 16))
    for c, cam in enumerate(cameras):
        E = np.asarray(cam.extrinsic, np.float64)[:3]
        rows[c, :12] = np.vstack([np.asarray(cam.K, np.float64)[:2] @ E, E[2:]]).ravel()
        rows[c, 12:15] = -E[:, :3].T @ E[:, 3]
        rows[c, 15] = cam.focal
    return rows


def joint_rows(body, patch_scale: float) -> np.ndarray:
    """(J, 4) float64 per joint: its rest position ``p_j`` (3, mm) and its patch size
    ``body.patch_mm[j] * patch_scale`` (mm)."""
    pivots = np.asarray(body.joint_rest_positions, np.float64)
    return np.c_[pivots, np.asarray(body.patch_mm, np.float64) * patch_scale]


def body_transforms(body, X: np.ndarray) -> np.ndarray:
    """(n, P) poses -> (n, J, 4, 4) float64 ``body.transforms(X)``; ValueError for another shape."""
    T = np.asarray(body.transforms(X), dtype=np.float64)
    J = len(body.joint_rest_positions)
    if T.shape != (len(X), J, 4, 4):
        raise ValueError(f"body.transforms returned shape {T.shape}, expected {(len(X), J, 4, 4)}")
    return T


def view_geometry(body, cameras, X: np.ndarray, patch_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Steps 1-2 and the coefficients of steps 3-4 for a batch, in float64, each operation
    rounded, in the order written here (the OpenCL kernel computes the same).

    Args:
        body (BodyModel): the body model (``transforms``, ``joint_rest_positions``, ``patch_mm``).
        cameras (list[Camera]): C cameras.
        X: (n, P) poses.
        patch_scale: factor on ``body.patch_mm``.

    Returns:
        coefficients: (n, C, J, 16) float32 per view and joint, ``A`` (3x4, row-major:
            ``u' v' z`` of a rest vertex), ``b = R^T t`` (culling: ``n' . p = n . v + n . b``)
            and a 0, rounded once from float64.
        side: (n, C, J) int64 patch side in pixels, 0 where the joint is dropped.
    """
    T = body_transforms(body, X)
    cams, joints = camera_rows(cameras), joint_rows(body, patch_scale)
    n, J, C = len(T), T.shape[1], len(cams)
    R = T[:, None, :, :3, :3]  # (n, 1, J, 3, 3)
    t = T[:, None, :, :3, 3]  # (n, 1, J, 3)
    P = cams[None, :, None, :12].reshape(1, C, 1, 3, 4)
    out = np.zeros((n, C, J, 16))
    A = out[..., :12].reshape(n, C, J, 3, 4)
    # A[i, k] = (P[i, 0] R[0, k] + P[i, 1] R[1, k]) + P[i, 2] R[2, k] for k < 3
    A[..., :3] = (P[..., :, 0, None] * R[..., None, 0, :] + P[..., :, 1, None] * R[..., None, 1, :]) + P[
        ..., :, 2, None
    ] * R[..., None, 2, :]
    # A[i, 3] = ((P[i, 0] t0 + P[i, 1] t1) + P[i, 2] t2) + P[i, 3]
    A[..., 3] = ((P[..., 0] * t[..., None, 0] + P[..., 1] * t[..., None, 1]) + P[..., 2] * t[..., None, 2]) + P[..., 3]
    # b[k] = (R[0, k] d0 + R[1, k] d1) + R[2, k] d2 with d = t - o
    d = t - cams[None, :, None, 12:15]  # (n, C, J, 3)
    out[..., 12:15] = (R[..., 0, :] * d[..., 0, None] + R[..., 1, :] * d[..., 1, None]) + R[..., 2, :] * d[..., 2, None]
    # z = ((A[2, 0] p0 + A[2, 1] p1) + A[2, 2] p2) + A[2, 3]; s = ceil((f * patch) / z)
    p = joints[:, :3]
    z = ((A[..., 2, 0] * p[:, 0] + A[..., 2, 1] * p[:, 1]) + A[..., 2, 2] * p[:, 2]) + A[..., 2, 3]
    ok = z > NEAR_MM
    raw = np.ceil((cams[:, 15, None] * joints[:, 3])[None] / np.where(ok, z, 1.0))
    side = np.where(ok, np.clip(raw, 1.0, MAX_SIDE), 0.0).astype(np.int64)
    return out.astype(np.float32), side


def vertex_table(body, patch_scale: float) -> np.ndarray:
    """(7, N) float32 per vertex, in the body's order: ``x, y, z`` (mm), unit normal
    ``nx, ny, nz`` and ``nv = n . v`` (mm), each computed in float64 and rounded once.

    ``v`` is the skin vertex moved inward along its normal by half its joint's patch side,
    ``v = v_skin - (body.patch_mm[j] * patch_scale / 2) n``: a patch centred on a skin
    vertex reaches half a side beyond the skin, so that the union of the patches would be
    the skin's silhouette dilated all round, and the fitness would prefer a body thinner
    than the person."""
    n = np.asarray(body.rest_normals, np.float64)
    inset = np.asarray(body.patch_mm, np.float64)[np.asarray(body.vertex_joint)] * (patch_scale / 2)
    v = np.asarray(body.rest_vertices, np.float64) - inset[:, None] * n
    return np.vstack([v.T, n.T, np.einsum("na,na->n", n, v)[None]]).astype(np.float32)


def project(coefficients: np.ndarray, table: np.ndarray) -> tuple[np.ndarray, ...]:
    """Steps 3-4 of the rule in float32, vectorised.

    Args:
        coefficients: (16, ...) float32, those of :func:`view_geometry` along the first axis.
        table: (7, ...) float32, :func:`vertex_table` rows; the trailing shapes broadcast.

    Returns:
        keep (...) bool, and the centre pixels cx, cy (...) float32 (meaningless where not kept).
    """
    a = coefficients
    x, y, z, nx, ny, nz, nv = table
    facing = nv + (nx * a[12] + ny * a[13] + nz * a[14]) < 0
    depth = a[8] * x + a[9] * y + a[10] * z + a[11]
    keep = facing & (depth > np.float32(NEAR_MM))
    half = np.float32(0.5)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        r = np.float32(1) / depth
        cx = np.floor((a[0] * x + a[1] * y + a[2] * z + a[3]) * r + half)
        cy = np.floor((a[4] * x + a[5] * y + a[6] * z + a[7]) * r + half)
    return keep, cx, cy


def keypoint_pixels(coefficients: np.ndarray, joint: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """Project model points with the silhouette rule's float32 arithmetic.

    With ``a`` the float32 coefficients of the point's joint in a view
    (:func:`view_geometry`) and ``x, y, z`` its rest position
    rounded to float32, in IEEE single precision, each operation rounded, no fused
    multiply-add, sums left to right::

        depth = a20 * x + a21 * y + a22 * z + a23
        r = 1 / depth
        u = (a00 * x + a01 * y + a02 * z + a03) * r
        v = (a10 * x + a11 * y + a12 * z + a13) * r

    and NaN for both where ``depth <= NEAR_MM``.

    Args:
        coefficients: (n, C, J, 16) float32.
        joint: (K,) int joint of each point.
        rest: (K, 3) rest positions, mm.

    Returns:
        (n, C, K, 2) float32 pixel coordinates, C-contiguous (as every backend's: the
        keypoint term's sums follow the memory order).
    """
    a = np.moveaxis(coefficients[:, :, joint, :], -1, 0)  # (16, n, C, K)
    x, y, z = np.asarray(rest, np.float32).T
    depth = a[8] * x + a[9] * y + a[10] * z + a[11]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        r = np.float32(1) / depth
        u = (a[0] * x + a[1] * y + a[2] * z + a[3]) * r
        v = (a[4] * x + a[5] * y + a[6] * z + a[7]) * r
    out = np.ascontiguousarray(np.stack([u, v], axis=-1))
    out[~(depth > np.float32(NEAR_MM))] = np.nan
    return out


def fitness_from_counts(model_px: np.ndarray, overlap_px: np.ndarray, fg_px: np.ndarray) -> np.ndarray:
    """Eq. 6-7 from pixel counts.

    Args:
        model_px: (n, C) ``|M_c|`` per candidate and camera.
        overlap_px: (n, C) ``|M_c & F_c|``.
        fg_px: (C,) ``|F_c|``.

    Returns:
        (n,) float64 fitness in [0, 1], the mean over cameras of ``f_c``.
    """
    m = np.asarray(model_px, dtype=np.float64)
    o = np.asarray(overlap_px, dtype=np.float64)
    f = np.asarray(fg_px, dtype=np.float64)
    if m.ndim != 2 or o.shape != m.shape or f.shape != m.shape[1:]:
        raise ValueError(
            f"model_px, overlap_px and fg_px must be (n, C), (n, C) and (C,), got {m.shape}, {o.shape} and {f.shape}"
        )
    model_term = np.where(m > 0, (m - o) / (2 * np.maximum(m, 1)), 0.5)
    fg_term = np.where(f > 0, (f - o) / (2 * np.maximum(f, 1)), 0.5)
    per_view = np.where((m == 0) & (f == 0), 0.0, model_term + fg_term)
    return np.add.reduce(per_view, axis=1) / m.shape[1]  # the mean's own sum and division, without its wrapper


def check_poses(X: np.ndarray) -> np.ndarray:
    """(n, P) poses as float64; ValueError for another shape or a row with NaN or inf."""
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2:
        raise ValueError(f"poses must be an (n, P) array, got shape {X.shape}")
    if np.isfinite(X).all():
        return X
    bad = np.flatnonzero(~np.isfinite(X).all(axis=1))
    if bad.size:
        raise ValueError(f"pose row {bad[0]} contains NaN or inf ({bad.size} bad rows)")
    return X


def check_foreground(cameras, foreground) -> list[np.ndarray]:
    """One (height, width) mask per camera -> list of (H_c, W_c) bool; DataError otherwise."""
    if not hasattr(foreground, "__len__"):
        raise DataError(
            f"foreground must be a list with one (height, width) mask per camera, got {type(foreground).__name__}"
        )
    if len(foreground) != len(cameras):
        raise DataError(
            f"got {len(foreground)} foreground masks for {len(cameras)} cameras "
            f"({', '.join(cam.name for cam in cameras)})"
        )
    masks = []
    for cam, mask in zip(cameras, foreground):
        mask = np.asarray(mask)
        if mask.shape != (cam.height, cam.width):
            raise DataError(
                f"foreground mask of camera {cam.name} has shape {mask.shape}, "
                f"expected {(cam.height, cam.width)} (height, width)"
            )
        if mask.dtype != bool and not np.issubdtype(mask.dtype, np.number):
            raise DataError(
                f"foreground mask of camera {cam.name} has dtype {mask.dtype}, "
                "expected bool or numbers (nonzero = foreground)"
            )
        masks.append(np.array(mask, dtype=bool))  # a copy; nonzero = foreground
    return masks


def check_body(body) -> None:
    """ValueError unless the body's arrays have consistent shapes (see SilhouetteEvaluator)."""
    v = np.asarray(body.rest_vertices)
    n = np.asarray(body.rest_normals)
    vj = np.asarray(body.vertex_joint)
    pivots = np.asarray(body.joint_rest_positions)
    patch = np.asarray(body.patch_mm)
    J = len(pivots)
    if v.ndim != 2 or v.shape[1] != 3 or n.shape != v.shape or vj.shape != (len(v),):
        raise ValueError(
            f"body: rest_vertices {v.shape}, rest_normals {n.shape} and vertex_joint "
            f"{vj.shape} must be (N, 3), (N, 3) and (N,)"
        )
    if pivots.shape != (J, 3) or patch.shape != (J,):
        raise ValueError(
            f"body: joint_rest_positions {pivots.shape} and patch_mm {patch.shape} must be (J, 3) and (J,)"
        )
    if vj.size and (not np.issubdtype(vj.dtype, np.integer) or vj.min() < 0 or vj.max() >= J):
        raise ValueError(f"body: vertex_joint must hold joint indices in [0, {J})")


class _OneBlasThread:
    """BLAS on one thread while at least one evaluator has claimed it; the original limits
    come back when the last one releases it."""

    def __init__(self):
        self.users = 0
        self.original = None  # the threadpoolctl limiter that holds the original limits

    def claim(self) -> None:
        self.users += 1
        limiter = threadpool_limits(1, user_api="blas")  # again, should it have changed since
        if self.original is None:
            self.original = limiter

    def release(self) -> None:
        self.users -= 1
        if self.users == 0 and self.original is not None:
            self.original.restore_original_limits()
            self.original = None


_BLAS = _OneBlasThread()


#: Default factor on the body's per-joint patch side (Cano Eq. 4) of every evaluator: at 1.0
#: the vertex patches leave holes between samples.
PATCH_SCALE = 1.5


class SilhouetteEvaluator:
    """Base class of the silhouette backends: validation, fitness and lifecycle.

    Args:
        patch_scale: factor on the body's per-joint patch size (Cano Eq. 4), > 0.

    The body passed to :meth:`setup` provides ``rest_vertices`` (N, 3) mm, ``rest_normals``
    (N, 3) unit, ``vertex_joint`` (N,) int, ``joint_rest_positions`` (J, 3) mm, ``patch_mm``
    (J,) mm and ``transforms(X)``: (n, P) -> (n, J, 4, 4) rigid rest-to-world transforms;
    optionally ``chain``, a :class:`~mmocap.body.kinematics.KinematicChain` whose
    ``transforms`` are ``body.transforms``, from which a backend may compute them itself.

    Subclasses implement ``_counts(X)`` and ``_render(x, camera_index)``, may extend
    ``_prepare()``, called at the end of :meth:`setup`, set ``name`` to their entry-point
    name, and override :meth:`unavailable` when they need what may not be installed.
    """

    #: the entry-point name of the backend (see :class:`mmocap.api.Evaluator`)
    name = ""

    #: True for a backend whose own workers keep every CPU core busy during a call: from
    #: :meth:`setup` to :meth:`close`, BLAS in this process then runs on one thread. Idle
    #: OpenBLAS threads spin after each call (an optimiser's eigendecomposition, say) and
    #: take the cores from the workers: CMA-ES frames on PoCL took 1.35x as long.
    owns_cores = False
    #: True for a backend that starts worker processes of its own: it cannot run inside
    #: a launcher's worker processes (joblib's are daemons), which the sweep checks.
    starts_processes = False

    @classmethod
    def unavailable(cls) -> str | None:
        """Why this backend cannot run here, one line with what to install (``mmocap list``
        shows it, and asking for the backend is a ConfigError saying it); None when it can."""
        return None

    def __init__(self, patch_scale: float = PATCH_SCALE):
        try:
            patch_scale = float(patch_scale)
        except (TypeError, ValueError):
            raise ConfigError(f"patch_scale must be a number, got {patch_scale!r}") from None
        if not (np.isfinite(patch_scale) and patch_scale > 0):
            raise ConfigError(f"patch_scale must be a finite number > 0, got {patch_scale}")
        self.patch_scale = patch_scale
        self.body: Any = None  # the frame's body model (see setup), duck-typed
        self.cameras: list = []
        self.foreground: list[np.ndarray] = []
        self.fg_px = np.zeros(0, dtype=np.int64)
        self.keypoints: Keypoints | None = None
        self._claimed_cores = False

    def setup(self, body, cameras, foreground, keypoints: Keypoints | None = None) -> None:
        """Upload one frame: the body, C cameras, C (H_c, W_c) bool-like foreground masks and
        optionally the C cameras' 2-D keypoints, which add the keypoint term to the fitness
        (:mod:`mmocap.evaluators.keypoint_term`)."""
        cameras = list(cameras)
        if not cameras:
            raise DataError("the evaluator needs at least one camera")
        check_body(body)
        self.foreground = check_foreground(cameras, foreground)
        self.fg_px = np.array([np.count_nonzero(m) for m in self.foreground], dtype=np.int64)
        self.cameras = cameras
        self.body = body
        self._set_keypoints(keypoints)
        if self.owns_cores and not self._claimed_cores:
            _BLAS.claim()
            self._claimed_cores = True
        self._prepare()

    def _set_keypoints(self, keypoints: Keypoints | None) -> None:
        self.keypoints = keypoints
        if keypoints is None:
            return
        if len(keypoints.observed) != len(self.cameras):
            raise DataError(f"got keypoints of {len(keypoints.observed)} cameras for {len(self.cameras)} cameras")
        J = len(self.body.joint_rest_positions)
        self._point_joint, self._point_rest = model_points(self.body, keypoints.points, keypoints.offsets_mm)
        if self._point_joint.size and self._point_joint.max() >= J:
            raise DataError(
                f"keypoints: the body has {J} joints, too few for the model points {', '.join(keypoints.points)}"
            )
        self._height_px = np.array([person_height_px(m) for m in self.foreground])

    def _prepare(self) -> None:
        """Backend hook: per-frame precomputation after :meth:`setup` stored its inputs."""

    def _require_setup(self) -> None:
        if self.body is None:
            raise RuntimeError(f"{type(self).__name__}: call setup(body, cameras, foreground) first")

    def counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n, P) poses -> ``model_px`` ``|M_c|`` and ``overlap_px`` ``|M_c & F_c|``, (n, C) int64."""
        self._require_setup()
        X = check_poses(X)
        if len(X) == 0:
            empty = np.zeros((0, len(self.cameras)), dtype=np.int64)
            return empty, empty.copy()
        return self._counts(X)

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """(n, P) poses -> (n,) fitness (0 = perfect match): the silhouettes' in [0, 1], plus
        the weighted keypoint term when the frame has keypoints."""
        if self.keypoints is None or self.keypoints.term.weight == 0:
            return self.silhouette_fitness(X)
        model_px, overlap_px, pixels = self.counts_and_pixels(X)
        term = self.keypoints.term
        silhouette = fitness_from_counts(model_px, overlap_px, self.fg_px)
        return silhouette + term.weight * term.value(pixels, self.keypoints.observed, self._height_px)

    def silhouette_fitness(self, X: np.ndarray) -> np.ndarray:
        """(n, P) poses -> (n,) the silhouettes' fitness alone, in [0, 1], keypoints or not."""
        model_px, overlap_px = self.counts(X)
        return fitness_from_counts(model_px, overlap_px, self.fg_px)

    def counts_and_pixels(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n, P) poses -> the counts of :meth:`counts` and the model points' pixels
        (n, C, K, 2) float32 (:func:`~mmocap.evaluators.keypoint_term.keypoint_pixels`),
        equal for every backend; K = 0 without keypoints."""
        self._require_setup()
        X = check_poses(X)
        if self.keypoints is None:
            return *self.counts(X), np.zeros((len(X), len(self.cameras), 0, 2), np.float32)
        if len(X) == 0:
            empty = np.zeros((0, len(self.cameras)), dtype=np.int64)
            return empty, empty.copy(), np.zeros((0, len(self.cameras), len(self._point_joint), 2), np.float32)
        return self._counts_and_pixels(X)

    def _counts_and_pixels(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Backend hook: counts and keypoint pixels in one pass; by default the counts, then
        the pixels from :func:`view_geometry` on the host."""
        model_px, overlap_px = self._counts(X)
        coefficients, _ = view_geometry(self.body, self.cameras, X, self.patch_scale)
        return model_px, overlap_px, keypoint_pixels(coefficients, self._point_joint, self._point_rest)

    def render(self, x: np.ndarray, camera_index: int) -> np.ndarray:
        """(P,) pose -> (H, W) bool model silhouette ``M_c`` in camera ``camera_index``."""
        self._require_setup()
        x = check_poses(np.asarray(x, dtype=np.float64)[None])[0]
        if not 0 <= camera_index < len(self.cameras):
            raise IndexError(f"camera_index {camera_index} is out of range for {len(self.cameras)} cameras")
        return self._render(x, int(camera_index))

    def _counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _render(self, x: np.ndarray, camera_index: int) -> np.ndarray:
        raise NotImplementedError

    def close(self) -> None:
        """Release the frame's data; :meth:`setup` may be called again afterwards."""
        self.body = None
        self.cameras = []
        self.foreground = []
        self.fg_px = np.zeros(0, dtype=np.int64)
        self.keypoints = None
        if self._claimed_cores:
            _BLAS.release()
            self._claimed_cores = False

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
