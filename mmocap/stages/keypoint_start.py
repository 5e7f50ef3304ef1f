"""The first frame's pose and the body's height from 2-D keypoints (the start's geometry).

:meth:`mmocap.stages.initialisation.AutoStart.find`, given the first frame's keypoints
(:class:`~mmocap.evaluators.keypoint_term.Keypoints`), starts from them instead of
searching the silhouettes (it refines the pose found here with the hybrid fitness):

1. **Triangulation** (:func:`triangulate`): each model point seen by at least two cameras
   is triangulated by a confidence-weighted DLT over the cameras (ideal pin-holes,
   ``K [R | t]`` in mm). A detector's misplaced or swapped joint in one camera would pull
   a least-squares point away from the others, so it is found by RANSAC over the camera
   pairs: the pair whose point reprojects within ``inlier_px`` (px) of the detections in
   the most cameras (confidence-weighted; ties: the least reprojection error) gives the
   inliers, and the point is triangulated again from those alone. Two cameras cannot
   outvote each other: a point seen by two is kept when each is within ``inlier_px`` of
   the other's ray.
2. **Placement** (:func:`placed_pose`): the heading is the yaw that turns the model's
   left-right axis (x) onto the horizontal part of the triangulated left-minus-right
   vectors of the hips and the shoulders (world y is up); the root is placed so that the
   pelvis's points (``Root``, ``LHip``, ``RHip``, those triangulated) fall on theirs.
3. **Height** (:func:`fitted_height_mm`): the model's points scale with the body's
   height; the distances between each point and its parent joint's point (rigid, whatever
   the pose) measured on the triangulated points, against the model's, give the height,
   within :data:`mmocap.body.mesh.HEIGHT_RANGE_MM`.
4. **Joint angles** (:func:`fit_points`): bounded least squares of the model points
   against the triangulated ones over the body's active degrees of freedom, each joint
   angle pulled towards the rest pose as :func:`mmocap.body.inverse_kinematics.fit_pose`
   pulls it (:data:`~mmocap.body.inverse_kinematics.REST_PULL_MM_PER_RAD`).

World axes are mmocap's (y up, mm); model axes x to the subject's left, y up, z forward.
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from mmocap.body.inverse_kinematics import REST_PULL_MM_PER_RAD
from mmocap.body.keypoints import model_points, posed_points
from mmocap.body.mesh import HEIGHT_RANGE_MM
from mmocap.body.model import BodyModel
from mmocap.body.skeleton import JOINTS, PARENT_INDEX, parameter_index

log = logging.getLogger(__name__)

#: the model points rigid with the root: they place it
PELVIS = ("Root", "LHip", "RHip")
#: left and right model points whose difference points to the subject's left (model +x)
LEFT_RIGHT_PAIRS = (("LHip", "RHip"), ("LShoulder", "RShoulder"))
#: the parent of each model point that rides on a joint: the point of the parent joint
#: (``Nose`` rides on ``Neck``); distances to it are rigid
POINT_PARENT = {
    **{joint: JOINTS[parent] for joint, parent in zip(JOINTS, PARENT_INDEX) if parent >= 0},
    "Nose": "Neck",
}
_ROOT_YAW = parameter_index("Root.ry")
#: the most residual evaluations of the joint angles' least-squares fit (its Jacobian's not counted)
FIT_EVALUATIONS = 200
#: the least depth (mm) in front of a camera of a triangulated point it sees
NEAR_MM = 1.0


def _dlt(projections: np.ndarray, pixels: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(3,) mm the point whose projections by ``projections`` (n, 3, 4) best match ``pixels``
    (n, 2) in the algebraic sense: the linear equations ``u P_3 - P_1 = 0``, ``v P_3 - P_2 = 0``
    of each camera, each scaled to a unit 3-vector on the point (an error along it is a
    distance in the image plane at unit depth) and weighted by ``weights`` (n,), solved in
    the least-squares sense for the inhomogeneous point (the homogeneous SVD solution is
    biased by the coordinates' scales); NaN when the system is degenerate."""
    rows = np.concatenate(
        [
            pixels[:, :1] * projections[:, 2] - projections[:, 0],
            pixels[:, 1:] * projections[:, 2] - projections[:, 1],
        ]
    )
    rows *= (np.tile(weights, 2) / np.linalg.norm(rows[:, :3], axis=1))[:, None]
    point, _, rank, _ = np.linalg.lstsq(rows[:, :3], -rows[:, 3], rcond=None)
    return point if rank == 3 else np.full(3, np.nan)


def _reprojection_px(projections: np.ndarray, pixels: np.ndarray, point: np.ndarray) -> np.ndarray:
    """(n,) px distance between ``point`` (3,) mm projected by ``projections`` (n, 3, 4) and
    ``pixels`` (n, 2); infinite where the point is not in front of the camera."""
    image = projections @ np.r_[point, 1.0]
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = np.hypot(*(image[:, :2] / image[:, 2:] - pixels).T)
    return np.where(image[:, 2] > NEAR_MM, distance, np.inf)


def triangulate_point(projections: np.ndarray, observed: np.ndarray, inlier_px: float) -> tuple[np.ndarray, np.ndarray]:
    """One model point from its detections in C cameras (step 1 of the module docstring).

    Args:
        projections: (C, 3, 4) ideal pin-hole projections ``K [R | t]`` (world mm -> px).
        observed: (C, 3) u, v (px) and confidence; confidence 0 = not seen.
        inlier_px: the largest reprojection distance of an inlier, px.

    Returns:
        (3,) mm, NaN unless two cameras agree; (C,) bool, the cameras it was triangulated from.
    """
    seen = np.flatnonzero(observed[:, 2] > 0)
    none = np.full(3, np.nan), np.zeros(len(observed), bool)
    if len(seen) < 2:
        return none
    P, uv, w = projections[seen], observed[seen, :2], observed[seen, 2]
    best, best_score = None, (0.0, -np.inf)
    for a, b in itertools.combinations(range(len(seen)), 2):
        point = _dlt(P[[a, b]], uv[[a, b]], w[[a, b]])
        if not np.isfinite(point).all():
            continue
        error = _reprojection_px(P, uv, point)
        inliers = error <= inlier_px
        if not (inliers[a] and inliers[b]):
            continue
        score = (float(w[inliers].sum()), -float(error[inliers].sum()))
        if score > best_score:
            best, best_score = inliers, score
    if best is None:
        return none
    point = _dlt(P[best], uv[best], w[best])
    used = np.zeros(len(observed), bool)
    used[seen[best]] = True
    return point, used


def triangulate(cameras, observed: np.ndarray, inlier_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Every model point of one frame (:func:`triangulate_point`).

    Args:
        cameras: C cameras (``projection_matrix``: ideal pin-hole, mm -> px).
        observed: (C, K, 3) u, v (px of the ideal camera) and confidence of K points;
            confidence 0 = not seen.
        inlier_px: the largest reprojection distance of an inlier, px.

    Returns:
        (K, 3) mm, NaN for points fewer than two cameras agree on; (C, K) bool inliers.
    """
    observed = np.asarray(observed, np.float64)
    projections = np.stack([camera.projection_matrix for camera in cameras])
    points = np.full((observed.shape[1], 3), np.nan)
    inliers = np.zeros(observed.shape[:2], bool)
    for k in range(observed.shape[1]):
        points[k], inliers[:, k] = triangulate_point(projections, observed[:, k], inlier_px)
    return points, inliers


def _index(names) -> dict[str, int]:
    return {name: k for k, name in enumerate(names)}


def locates_pelvis_and_heading(names, points: np.ndarray) -> bool:
    """Whether the triangulated ``points`` (K, 3) mm of the model points ``names`` place the
    root (``Root``, or both hips) and give a heading (both hips, or both shoulders)."""
    found = {name for name, p in zip(names, points) if np.isfinite(p).all()}
    pelvis = "Root" in found or {"LHip", "RHip"} <= found
    return pelvis and any({left, right} <= found for left, right in LEFT_RIGHT_PAIRS)


def fitted_height_mm(body, names, points: np.ndarray, offsets_mm=None) -> float | None:
    """The standing height (mm) at which ``body``'s model points ``names`` best match the
    triangulated ``points`` (K, 3) mm: the body's height times the ratio of the summed
    point-to-parent distances, triangulated against the model's, clipped to
    :data:`~mmocap.body.mesh.HEIGHT_RANGE_MM`; None without any such pair.
    ``offsets_mm``: (K, 3) definition offsets, mm (:func:`mmocap.body.keypoints.model_points`)."""
    _, rest = model_points(body, names, offsets_mm)
    index = _index(names)
    measured = model = 0.0
    for name, k in index.items():
        parent = index.get(POINT_PARENT.get(name, ""))
        if parent is None or not np.isfinite(points[[k, parent]]).all():
            continue
        measured += float(np.linalg.norm(points[k] - points[parent]))
        model += float(np.linalg.norm(rest[k] - rest[parent]))
    if model == 0:
        return None
    return float(np.clip(body.subject.height_mm * measured / model, *HEIGHT_RANGE_MM))


def _yaw(vector: np.ndarray) -> float:
    """The yaw (rad, about +y) that turns the model's +x onto the horizontal part of ``vector`` (3,)."""
    return float(np.arctan2(-vector[2], vector[0]))


def placed_pose(body, names, points: np.ndarray, offsets_mm=None) -> np.ndarray:
    """(51,) the rest pose turned to the triangulated heading and placed on the pelvis (step
    2 of the module docstring), from ``points`` (K, 3) mm (NaN = not triangulated) of the
    model points ``names`` with ``offsets_mm`` (K, 3) mm; needs
    :func:`locates_pelvis_and_heading`."""
    joint, rest = model_points(body, names, offsets_mm)
    index = _index(names)
    world_left, model_left = np.zeros(3), np.zeros(3)
    for left, right in LEFT_RIGHT_PAIRS:
        if left in index and right in index and np.isfinite(points[[index[left], index[right]]]).all():
            world_left += points[index[left]] - points[index[right]]
            model_left += rest[index[left]] - rest[index[right]]
    x = np.zeros_like(body.lower)
    x[_ROOT_YAW] = _yaw(world_left) - _yaw(model_left)
    pelvis = [index[name] for name in PELVIS if name in index and np.isfinite(points[index[name]]).all()]
    at_origin = posed_points(body, x[None], joint[pelvis], rest[pelvis])[0]
    x[:3] = (points[pelvis] - at_origin).mean(axis=0)
    return x


def fit_points(body, x: np.ndarray, names, points: np.ndarray, offsets_mm=None) -> np.ndarray:
    """(51,) the pose, from ``x`` (51,), whose model points ``names`` (with ``offsets_mm``
    (K, 3) mm) best match the triangulated ``points`` (K, 3) mm (NaN = missing): bounded
    least squares over the active (``body.mask``) parameters within ``body.lower`` /
    ``body.upper``, each joint angle pulled towards the rest pose by
    :data:`~mmocap.body.inverse_kinematics.REST_PULL_MM_PER_RAD`."""
    joint, rest = model_points(body, names, offsets_mm)
    present = np.isfinite(points).all(axis=1)
    joint, rest, target = joint[present], rest[present], points[present]
    free = body.mask & (body.lower < body.upper)
    angle = free.copy()
    angle[:6] = False
    x = np.asarray(x, np.float64).copy()

    def residual(values):
        x[free] = values
        return np.r_[(posed_points(body, x[None], joint, rest)[0] - target).ravel(), REST_PULL_MM_PER_RAD * x[angle]]

    start = np.clip(x[free], body.lower[free], body.upper[free])
    # tolerances in the residual's own units (mm): a hundredth of a millimetre is plenty, and a
    # real recording's points (no pose fits them exactly) took 36 s to the default 1e-8
    result = least_squares(
        residual,
        start,
        bounds=(body.lower[free], body.upper[free]),
        x_scale="jac",
        ftol=1e-5,
        xtol=1e-5,
        max_nfev=FIT_EVALUATIONS,
    )
    x[free] = result.x
    return x


@dataclass
class KeypointFit:
    """What :func:`fit_keypoints` found: the ``body`` (resized to the fitted height, if
    fitted), its ``pose`` (51,) mm and rad, the triangulated ``points`` (K, 3) mm (NaN = not
    triangulated), the ``inliers`` (C, K) bool and the mean distance of the posed model
    points from the triangulated ones, ``residual_mm``."""

    body: BodyModel
    pose: np.ndarray
    points: np.ndarray
    inliers: np.ndarray
    residual_mm: float


def fit_keypoints(
    body, cameras, keypoints, inlier_px: float, fit_height: bool, girth: float | None = None
) -> KeypointFit | None:
    """Steps 1-4 of the module docstring for ``body`` (a BodyModel) from ``keypoints``
    (:class:`~mmocap.evaluators.keypoint_term.Keypoints`, px of the ideal ``cameras``);
    ``fit_height``: whether the body's height is fitted; ``girth``: the girth the body is
    given (None: its own). None (and a log line saying why) when the triangulated points
    place no pelvis or give no heading."""
    names, offsets = keypoints.points, keypoints.offsets_mm
    points, inliers = triangulate(cameras, keypoints.observed, inlier_px)
    if not locates_pelvis_and_heading(names, points):
        log.warning(
            "automatic start: the keypoints triangulate %d of %d points, without the pelvis (Root or both hips) "
            "and a left-right pair (hips or shoulders) seen by 2 cameras; searching the silhouettes instead",
            int(np.isfinite(points).all(axis=1).sum()),
            len(names),
        )
        return None
    height = fitted_height_mm(body, names, points, offsets) if fit_height else None
    if height is not None or girth is not None:
        body = body.reshaped(height_mm=height, girth=girth)
    x = fit_points(body, placed_pose(body, names, points, offsets), names, points, offsets)
    joint, rest = model_points(body, names, offsets)
    present = np.isfinite(points).all(axis=1)
    residual = np.linalg.norm(posed_points(body, x[None], joint, rest)[0] - points, axis=1)[present].mean()
    log.info(
        "automatic start: %d of %d keypoints triangulated (%d detections rejected), body %.0f mm tall, "
        "model points %.0f mm from them",
        int(present.sum()),
        len(names),
        int(((keypoints.observed[..., 2] > 0) & ~inliers)[:, present].sum()),
        body.subject.height_mm,
        residual,
    )
    return KeypointFit(body, x, points, inliers, float(residual))
