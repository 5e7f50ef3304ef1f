"""Stage "initialisation": the first frame's pose, and the body's size, from the silhouettes
and, where the first frame has them, 2-D keypoints.

A user's recording gives no first pose (``x0``) and no body dimensions. :class:`AutoStart`
finds both on cameras no larger than ``max_image_px`` (a full-HD camera, its mask and its
keypoints are shrunk for the start, which then costs what it does at 640x480).

**From keypoints** (``method: keypoints`` in the summary), when the first frame's
keypoints triangulate the pelvis (``Root`` or both hips) and the hips' or the shoulders'
left-right axis: the pose, the heading and the body's height are fitted to the triangulated
points (:mod:`mmocap.stages.keypoint_start`, RANSAC inliers within ``keypoint_inlier_px``),
then searched by the run's optimiser in the tracking strategy's box with the hybrid
fitness (silhouettes + the keypoints' term, weighted as the keypoints say) for
``keypoint_evaluations``; one pass of the girth and height trials of step 4 below follows,
then each step but the root searched over its whole joint range (``keypoint_limb_evaluations``
each; :func:`search_each_limb` without random samples) and the full pose again, all scored
by the hybrid fitness. The visual hull of step 1 is measured too, for the
plausibility checks. With the defaults this is 14 200 evaluations: 4.0-4.8 s at 640x480
with four cameras (OpenCL on two cores shared with other jobs; the silhouette search took
33 s, 282 424 evaluations, on the same scene and machine).

**From the silhouettes alone** (``method: search``), without keypoints or when they do not
place the person:

1. **Where:** the rays through the centroids of the silhouettes, one per camera, meet (in
   the least-squares sense) near the person's centre; a visual hull is carved around that
   point (:func:`visual_hull`: voxels inside the foreground of every camera that sees them),
   first coarse, then fine inside the coarse hull's box. The hull's lowest voxel is the
   floor under the person, its height is the person's standing height (unless
   ``body.height_mm`` is given), and its centre gives the root's position on the floor
   plane. A hull reaches below the soles (the cameras' cones under a foot meet lower
   than the foot: 26-78 mm on the nine synthetic sequences), so steps 2-3 run for each
   height of ``hull_height_offsets_mm`` added to the hull's, and the best fit goes on.
2. **Heading:** the rest pose at that position is scored at ``headings`` yaw angles over a
   full turn, because people face any way; the ``candidates`` best headings go on.
3. **Pose:** from each of them, the run's optimiser searches the full pose with
   ``evaluations`` (a box of ``rotation_radius`` and ``translation_radius_mm`` around the
   current estimate); from the ``refined`` best, ``passes`` times: each step of the strategy but the
   root (torso and head, each arm, each leg) searched alone over its whole joint range
   (:func:`search_each_limb`: ``limb_samples`` random poses of the limb, then searches from
   the current pose and the ``limb_restarts`` best samples, ``limb_evaluations`` in all),
   then the full pose ``rounds`` times.
4. **Shape:** the body starts at girth 1 (the base mesh); each girth offset of
   ``girth_steps`` (unless ``body.girth`` is given) and then each height offset of
   ``height_steps_mm`` (unless ``body.height_mm`` is given) is tried with a short search
   from the best pose, and kept if its fitness is lower. This is done ``shape_passes``
   times, the pose refined as in step 3 again before each pass after the first: a limb
   posed to fit a wrong body keeps a body of the right size from fitting better. The body
   kept tracks the whole sequence. The preset's dimensions (``body.subject``) are never
   used for what is fitted: they are unknown for a recording.

World axes are mmocap's (y up, mm). The cost (seconds, evaluations) is returned and
recorded in the run's summary.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np

from mmocap.bitmask import ForegroundMask
from mmocap.body.mesh import GIRTH_RANGE, HEIGHT_RANGE_MM
from mmocap.body.model import BodyModel
from mmocap.errors import ConfigError, DataError
from mmocap.evaluators.keypoint_term import Keypoints
from mmocap.stages.fidelity import shrunk_mask
from mmocap.stages.keypoint_start import KeypointFit, fit_keypoints
from mmocap.validate import check_choice, check_number

log = logging.getLogger(__name__)

#: what ``start.mode`` may be
START_MODES = ("auto", "search")
#: how a start was found (the summary's ``start.method``): from keypoints, or by the
#: silhouette-only search
START_METHODS = ("keypoints", "search")
#: the root's yaw parameter in the 51-vector (``Root.ry``) and the root translation
ROOT_YAW, ROOT_TRANSLATION = 4, slice(0, 3)
#: half the side of the cube, mm, in which the coarse visual hull is carved around the
#: point where the silhouettes' rays meet
HULL_REACH_MM = 1400.0
#: voxel side of the coarse hull, mm
COARSE_VOXEL_MM = 40.0


@dataclass
class StartResult:
    """What :meth:`AutoStart.find` found: ``pose`` (51,) mm and rad, its ``fitness``, the
    ``body`` it was found with (resized if shape fitting ran), the ``evaluations`` and
    ``seconds`` spent, what the visual hull measured (``height_mm``, ``floor_y_mm``), the
    ``method`` that found it (:data:`START_METHODS`) and the pose's ``silhouette_fitness``
    alone (``fitness`` has the keypoint term too when the start had keypoints)."""

    pose: np.ndarray
    fitness: float
    body: BodyModel
    evaluations: int
    seconds: float
    height_mm: float
    floor_y_mm: float
    method: str
    silhouette_fitness: float

    def summary(self) -> dict:
        """The facts a run records about its start (JSON types)."""
        return {
            "method": self.method,
            "seconds": round(self.seconds, 3),
            "evaluations": int(self.evaluations),
            "fitness": float(self.fitness),
            "silhouette_fitness": float(self.silhouette_fitness),
            "heading_rad": float(self.pose[ROOT_YAW]),
            "hull_height_mm": round(self.height_mm, 1),
            "floor_y_mm": round(self.floor_y_mm, 1),
            "body_height_mm": float(self.body.subject.height_mm),
            "body_girth": float(self.body.subject.girth),
        }


def silhouette_rays(cameras, masks) -> tuple[np.ndarray, np.ndarray]:
    """(C, 3) camera centres (mm) and (C, 3) unit directions of the rays through the
    centroids of the ``masks`` ((H, W) bool each, in the ideal geometry of ``cameras``);
    cameras whose mask is empty are left out."""
    centres, directions = [], []
    for camera, mask in zip(cameras, masks):
        rows, cols = np.nonzero(np.asarray(mask))
        if rows.size == 0:
            continue
        pixel = np.array([cols.mean(), rows.mean(), 1.0])
        direction = camera.R.T @ np.linalg.solve(camera.K, pixel)
        centres.append(camera.centre)
        directions.append(direction / np.linalg.norm(direction))
    return np.asarray(centres), np.asarray(directions)


def nearest_point_to_rays(centres: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(3,) the point with the least sum of squared distances to the rays (``centres`` +
    s ``directions``, (C, 3) each, unit directions); a DataError with fewer than two rays
    or parallel ones."""
    if len(centres) < 2:
        raise DataError(
            "the automatic start needs a person in the foreground of at least two cameras "
            f"in the first frame, found {len(centres)}: check the foreground, or give the first pose"
        )
    projectors = np.eye(3)[None] - directions[:, :, None] * directions[:, None, :]
    A = projectors.sum(axis=0)
    if np.linalg.cond(A) > 1e8:
        raise DataError(
            "the cameras' rays through the person's silhouettes are parallel: the cameras "
            "cannot place the person; give the first pose"
        )
    return np.linalg.solve(A, np.einsum("cij,cj->i", projectors, centres))


def visual_hull(
    cameras, masks, lower: np.ndarray, upper: np.ndarray, voxel_mm: float, min_views: int = 2
) -> np.ndarray:
    """(N, 3) mm centres of the voxels of side ``voxel_mm`` in the box ``lower``-``upper``
    ((3,) mm) that lie inside the foreground of every camera that sees them, and are seen
    by at least ``min_views`` cameras. ``masks``: (H, W) bool in the ideal geometry of
    ``cameras``."""
    axes = [np.arange(lo + voxel_mm / 2, hi, voxel_mm) for lo, hi in zip(lower, upper)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    inside = np.ones(len(points), bool)
    seen = np.zeros(len(points), np.int32)
    for camera, mask in zip(cameras, masks):
        mask = np.asarray(mask)
        if not mask.any():
            continue  # a camera without a person in view says nothing about where it is
        depth = points @ camera.R[2] + camera.t[2]
        uv = camera.project(points)
        col, row = np.floor(uv[:, 0] + 0.5).astype(np.int64), np.floor(uv[:, 1] + 0.5).astype(np.int64)
        visible = (depth > 0) & (col >= 0) & (col < camera.width) & (row >= 0) & (row < camera.height)
        seen += visible
        foreground = np.zeros(len(points), bool)
        foreground[visible] = mask[row[visible], col[visible]]
        inside &= ~visible | foreground
    return points[inside & (seen >= min_views)]


def search_each_limb(
    strategy, body, x, fitness: float, evaluator, optimizer, evaluations: int, rng, samples: int = 0, restarts: int = 0
):
    """Each step of ``strategy`` but the root (torso and head, each arm, each leg) searched
    alone over its whole joint range, from the pose ``x`` (51,) of ``fitness``, keeping what
    improves; returns (pose, fitness, evaluations used). A limb far from where it was (arms
    raised to a boxer's guard, a leg on the wrong side) lies outside the box of a tracking
    step, and a local search from the wrong pose seldom reaches it.

    Per limb: ``samples`` poses of the limb drawn uniformly over its joint range (the rest of
    the body held) are scored in one batch; then ``optimizer`` searches the whole range from
    ``x`` and from each of the ``restarts`` best samples, ``evaluations`` split evenly
    between these searches."""
    whole_range = type(strategy)(
        rotation_radius=np.pi, translation_radius_mm=strategy.translation_radius_mm, steps=strategy.steps
    )
    used = 0
    for parts in whole_range.step_groups(body, skip_empty=True)[1:]:
        starts = [x]
        if samples:
            limb = np.concatenate(parts)
            drawn = np.repeat(x[None], samples, axis=0)
            drawn[:, limb] = rng.uniform(body.lower[limb], body.upper[limb], size=(samples, len(limb)))
            scores = evaluator(drawn)
            used += samples
            starts += list(drawn[np.argsort(scores, kind="stable")[:restarts]])
        for start in starts:
            found, found_fitness, n = whole_range.search(
                body, start, parts, evaluator, optimizer, evaluations // len(starts), rng
            )
            used += n
            if found_fitness < fitness:
                x, fitness = found, found_fitness
    return x, fitness, used


def person_hull(cameras, masks, voxel_mm: float) -> np.ndarray:
    """(N, 3) mm centres of the voxels of the person's visual hull in one frame: a coarse hull
    around the point where the silhouettes' rays meet, then one of side ``voxel_mm`` (mm)
    around it. ``masks``: (H, W) bool in the ideal geometry of ``cameras``; a DataError when no
    volume lies inside every camera's foreground."""
    meet = nearest_point_to_rays(*silhouette_rays(cameras, masks))
    coarse = visual_hull(cameras, masks, meet - HULL_REACH_MM, meet + HULL_REACH_MM, COARSE_VOXEL_MM)
    if len(coarse) == 0:
        raise DataError(
            "the automatic start found no volume inside every camera's foreground in the first "
            "frame: the cameras' calibrations may not match the images, or the person is out of "
            "view of some camera; check with `mmocap check-recording`, or give the first pose"
        )
    pad = COARSE_VOXEL_MM
    hull = visual_hull(cameras, masks, coarse.min(axis=0) - pad, coarse.max(axis=0) + pad, voxel_mm)
    return coarse if len(hull) == 0 else hull


class AutoStart:
    """Hydra component (``start:`` in ``conf/config.yaml``): finds the first frame's pose
    when the sequence gives none (``mode=auto``), or always (``mode=search``: the sequence's
    ``x0`` is ignored, as when testing the search on data that has one).

    Args:
        mode: ``auto`` or ``search`` (see above).
        headings: yaw angles tried over a full turn (step 2 of the module docstring).
        candidates: best headings searched in full.
        evaluations: evaluations of each full-pose search.
        refined: best headings, after their full-pose search, refined as below.
        rounds: full-pose searches after the limbs' searches, in each pass.
        passes: limbs' searches and full-pose searches, this many times.
        rotation_radius: half-width of the search box of every rotation, rad.
        translation_radius_mm: half-width of the search box of the root position, mm.
        voxel_mm: voxel side of the fine visual hull, mm.
        girth_steps: offsets from the current girth (1 at first) tried once the pose is
            found ([] keeps girth 1).
        height_steps_mm: offsets (mm) from the current height (the visual hull's at first)
            tried after the girths ([] keeps the hull's height).
        shape_evaluations: evaluations of the search for each girth and height tried.
        shape_passes: passes of the girth and height trials, the pose refined before each
            pass after the first.
        limb_evaluations: evaluations of the searches of each step but the root (torso,
            each arm, each leg) over its whole joint range.
        limb_samples: random poses of each such step scored before its searches (0: none).
        limb_restarts: best of those samples each searched too, besides the current pose.
        hull_height_offsets_mm: offsets (mm) from the visual hull's height, each the body's
            height for steps 2-3 (unless ``body.height_mm`` is given).
        max_image_px: the longest image side the start searches on, px: larger cameras and
            their masks are shrunk to it for the start (:meth:`reduced`), so that its cost
            does not grow with the cameras' resolution (None: the images' own size).
        keypoint_evaluations: evaluations of each full-pose search (two) from the pose
            fitted to the keypoints, with the hybrid fitness.
        keypoint_limb_evaluations: evaluations of the search of each step but the root over
            its whole joint range, from the pose fitted to the keypoints.
        keypoint_inlier_px: the largest reprojection distance (px, in cameras shrunk to
            ``max_image_px``) of a detection that agrees with a triangulated point.
    """

    def __init__(
        self,
        mode: str = "auto",
        headings: int = 12,
        candidates: int = 4,
        evaluations: int = 2000,
        refined: int = 2,
        limb_evaluations: int = 2000,
        limb_samples: int = 2000,
        limb_restarts: int = 3,
        rounds: int = 3,
        passes: int = 2,
        rotation_radius: float = 0.6,
        translation_radius_mm: float = 200.0,
        voxel_mm: float = 15.0,
        girth_steps=(-0.1, 0.1),
        height_steps_mm=(-40.0, 40.0),
        shape_evaluations: int = 800,
        shape_passes: int = 2,
        hull_height_offsets_mm=(0.0, -40.0),
        max_image_px: int | None = 640,
        keypoint_evaluations: int = 3000,
        keypoint_limb_evaluations: int = 1000,
        keypoint_inlier_px: float = 15.0,
    ):
        self.mode = check_choice("start.mode", mode, START_MODES)
        self.headings = check_number("start.headings", headings, 1, 360, integer=True)
        self.candidates = check_number("start.candidates", candidates, 1, self.headings, integer=True)
        self.evaluations = check_number("start.evaluations", evaluations, 2, 10**7, integer=True)
        self.refined = check_number("start.refined", refined, 1, self.candidates, integer=True)
        self.rounds = check_number("start.rounds", rounds, 1, 100, integer=True)
        self.passes = check_number("start.passes", passes, 1, 100, integer=True)
        self.rotation_radius = check_number("start.rotation_radius", rotation_radius, 0, np.pi, low_open=True)
        self.translation_radius_mm = check_number(
            "start.translation_radius_mm", translation_radius_mm, 0, 5000, low_open=True
        )
        self.voxel_mm = check_number("start.voxel_mm", voxel_mm, 2, COARSE_VOXEL_MM)
        girth_span = GIRTH_RANGE[1] - GIRTH_RANGE[0]
        self.girth_steps = [check_number("start.girth_steps", g, -girth_span, girth_span) for g in girth_steps]
        self.height_steps_mm = [check_number("start.height_steps_mm", h, -500, 500) for h in height_steps_mm]
        self.limb_evaluations = check_number("start.limb_evaluations", limb_evaluations, 2, 10**7, integer=True)
        self.shape_evaluations = check_number("start.shape_evaluations", shape_evaluations, 2, 10**7, integer=True)
        self.hull_height_offsets_mm = [
            check_number("start.hull_height_offsets_mm", h, -500, 500) for h in hull_height_offsets_mm
        ]
        if not self.hull_height_offsets_mm:
            raise ConfigError(
                "start.hull_height_offsets_mm is empty: give at least one height offset (mm) "
                "from the visual hull's height, e.g. [0]"
            )
        self.max_image_px = (
            None if max_image_px is None else check_number("start.max_image_px", max_image_px, 64, integer=True)
        )
        self.shape_passes = check_number("start.shape_passes", shape_passes, 1, 100, integer=True)
        self.limb_samples = check_number("start.limb_samples", limb_samples, 0, 10**6, integer=True)
        self.limb_restarts = check_number("start.limb_restarts", limb_restarts, 0, self.limb_samples, integer=True)
        self.keypoint_evaluations = check_number(
            "start.keypoint_evaluations", keypoint_evaluations, 2, 10**7, integer=True
        )
        self.keypoint_limb_evaluations = check_number(
            "start.keypoint_limb_evaluations", keypoint_limb_evaluations, 2, 10**7, integer=True
        )
        self.keypoint_inlier_px = check_number("start.keypoint_inlier_px", keypoint_inlier_px, 0, 1000, low_open=True)

    def wanted(self, has_x0: bool) -> bool:
        """Whether to search: always with ``mode=search``, else when there is no ``x0``."""
        return self.mode == "search" or not has_x0

    def measure(self, cameras, masks) -> tuple[np.ndarray, float, float]:
        """The visual hull of one frame: ((3,) mm centre of the hull, its height in mm, the y
        of its lowest voxel in mm). ``masks``: (H, W) bool in the ideal geometry of ``cameras``."""
        hull = person_hull(cameras, masks, self.voxel_mm)
        floor_y = float(hull[:, 1].min() - self.voxel_mm / 2)
        height = float(hull[:, 1].max() + self.voxel_mm / 2 - floor_y)
        return hull.mean(axis=0), height, floor_y

    def find(
        self,
        body,
        cameras,
        masks,
        evaluator,
        optimizer,
        strategy,
        rng,
        fit_height: bool = True,
        fit_girth: bool = True,
        keypoints: Keypoints | None = None,
    ) -> StartResult:
        """The first frame's pose for ``body`` (a BodyModel, resized to what is fitted),
        from its foreground ``masks`` ((H, W) bool per camera, ideal geometry of
        ``cameras``) and, if given, its ``keypoints`` (px of the ideal ``cameras``), scored
        by ``evaluator`` and searched by ``optimizer`` in ``strategy``'s steps.
        ``fit_height`` / ``fit_girth``: whether the body's height / girth are unknown (not
        given in the config) and fitted."""
        started = time.perf_counter()
        if keypoints is not None and len(keypoints.observed) != len(cameras):
            raise DataError(
                f"the automatic start got the first frame's keypoints of {len(keypoints.observed)} cameras for "
                f"{len(cameras)} cameras: give one camera's keypoints per camera, in the cameras' order"
            )
        reduced, masks = self.reduced(cameras, masks)
        keypoints = None if keypoints is None else keypoints.on(cameras, reduced)
        cameras = reduced
        centre, height, floor_y = self.measure(cameras, masks)
        log.info(
            "automatic start: visual hull %.0f mm tall, centre (%.0f, %.0f, %.0f) mm, floor at y = %.0f mm",
            height,
            *centre,
            floor_y,
        )
        fit = None
        if keypoints is not None:
            girth = 1.0 if fit_girth else None
            fit = fit_keypoints(body, cameras, keypoints, self.keypoint_inlier_px, fit_height, girth)
        if fit is None:
            keypoints, method = None, "search"
            x, f, body, used = self._search(
                body,
                height,
                centre,
                floor_y,
                cameras,
                masks,
                evaluator,
                optimizer,
                strategy,
                rng,
                fit_height,
                fit_girth,
            )
        else:
            method = "keypoints"
            x, f, body, used = self._from_keypoints(
                fit, cameras, masks, keypoints, evaluator, optimizer, strategy, rng, fit_height, fit_girth
            )
        evaluator.setup(body, cameras, masks, keypoints)  # leave the evaluator on the body that won
        silhouettes = float(evaluator.silhouette_fitness(x[None])[0])
        seconds = time.perf_counter() - started
        return StartResult(x, float(f), body, used, seconds, height, floor_y, method, silhouettes)

    def _search(
        self, body, height, centre, floor_y, cameras, masks, evaluator, optimizer, strategy, rng, fit_height, fit_girth
    ):
        """Steps 2-4 of the module docstring from the visual hull's ``height`` (mm), ``centre``
        (3,) mm and ``floor_y`` (mm); returns (pose (51,), fitness, body, evaluations)."""
        search = type(strategy)(
            rotation_radius=self.rotation_radius, translation_radius_mm=self.translation_radius_mm, steps=strategy.steps
        )
        best_f, used = np.inf, 0
        for offset in self.hull_height_offsets_mm if fit_height else [0.0]:
            tried = body.reshaped(
                height_mm=float(np.clip(height + offset, *HEIGHT_RANGE_MM)) if fit_height else None,
                girth=1.0 if fit_girth else None,
            )
            x, f, n = self._pose(tried, centre, floor_y, cameras, masks, evaluator, optimizer, search, rng)
            used += n
            log.info("automatic start: height %.0f mm -> fitness %.4f", tried.subject.height_mm, f)
            if f < best_f:
                best_x, best_f, chosen = x, f, tried
        body = chosen
        shaped = (fit_girth and self.girth_steps) or (fit_height and self.height_steps_mm)
        for shape_pass in range(self.shape_passes if shaped else 0):
            if shape_pass:
                evaluator.setup(body, cameras, masks)
                best_x, best_f, n = self._refine(body, best_x, best_f, evaluator, optimizer, search, rng)
                used += n
            for change in self._shape_changes(body, fit_girth, fit_height):
                best_x, best_f, body, n = self._try_shape(
                    body, change, best_x, best_f, cameras, masks, evaluator, optimizer, search, rng
                )
                used += n
        return best_x, best_f, body, used

    def _from_keypoints(
        self, fit: KeypointFit, cameras, masks, keypoints, evaluator, optimizer, strategy, rng, fit_height, fit_girth
    ):
        """From the pose ``fit`` to the triangulated keypoints, with the hybrid fitness: a
        full-pose search (``keypoint_evaluations`` in ``strategy``'s box), one pass of girth
        and height trials, each step but the root searched over its whole joint range
        (``keypoint_limb_evaluations`` each), and a last full-pose search; returns (pose
        (51,), fitness, body, evaluations)."""
        body = fit.body
        evaluator.setup(body, cameras, masks, keypoints)
        x, f, used = strategy.estimate(body, fit.pose, evaluator, optimizer, self.keypoint_evaluations, rng)
        log.info("automatic start: the pose fitted to the keypoints, searched -> fitness %.4f", f)
        for change in self._shape_changes(body, fit_girth, fit_height):
            x, f, body, n = self._try_shape(
                body, change, x, f, cameras, masks, evaluator, optimizer, strategy, rng, keypoints
            )
            used += n
        evaluator.setup(body, cameras, masks, keypoints)
        x, f, n = search_each_limb(strategy, body, x, f, evaluator, optimizer, self.keypoint_limb_evaluations, rng)
        used += n
        x, f, n = strategy.estimate(body, x, evaluator, optimizer, self.keypoint_evaluations, rng)
        log.info("automatic start: limbs over their ranges, then the full pose -> fitness %.4f", f)
        return x, f, body, used + n

    def reduced(self, cameras, masks) -> tuple[list, list]:
        """``cameras`` and their (H, W) bool ``masks``, each camera whose longest side exceeds
        ``max_image_px`` shrunk to it (:meth:`mmocap.camera.Camera.shrunk`, masks by area,
        :func:`mmocap.stages.fidelity.shrunk_mask`); the others as they are."""
        if self.max_image_px is None:
            return list(cameras), list(masks)
        out_cameras, out_masks = [], []
        for camera, mask in zip(cameras, masks):
            scale = self.max_image_px / max(camera.width, camera.height)
            if scale < 1:
                camera = camera.shrunk(scale)
                mask = ForegroundMask(shrunk_mask(mask, camera.width, camera.height))
            out_cameras.append(camera)
            out_masks.append(mask)
        return out_cameras, out_masks

    def _pose(self, body, centre, floor_y: float, cameras, masks, evaluator, optimizer, search, rng):
        """Steps 2-3 for ``body``: the rest pose placed at the hull's ``centre`` (3,) mm
        with its soles at ``floor_y`` mm, turned to each heading, the best searched and
        refined; returns (pose (51,), fitness, evaluations)."""
        evaluator.setup(body, cameras, masks)
        placed = body.rest_pose()
        placed[ROOT_TRANSLATION] = (centre[0], floor_y + body.floor_offset_mm, centre[2])
        starts = np.repeat(placed[None], self.headings, axis=0)
        starts[:, ROOT_YAW] = np.arange(self.headings) * (2 * np.pi / self.headings) - np.pi
        scores = evaluator(starts)
        used = len(starts)
        scouted = []
        for k in np.argsort(scores, kind="stable")[: self.candidates]:
            x, f, n = search.estimate(body, starts[k], evaluator, optimizer, self.evaluations, rng)
            used += n
            log.info("automatic start: heading %+.0f deg -> fitness %.4f", np.degrees(starts[k, ROOT_YAW]), f)
            scouted.append((f, k, x))
        best_x, best_f = None, np.inf
        for f, _, x in sorted(scouted, key=lambda s: s[:2])[: self.refined]:
            x, f, n = self._refine(body, x, f, evaluator, optimizer, search, rng)
            used += n
            if f < best_f:
                best_x, best_f = x, f
        return best_x, best_f, used

    def _shape_changes(self, body, fit_girth: bool, fit_height: bool) -> list[dict]:
        """The girths, then the heights, of one pass of shape trials around ``body``'s."""
        return ([{"girth": body.subject.girth + g} for g in self.girth_steps] if fit_girth else []) + (
            [{"height_mm": body.subject.height_mm + dh} for dh in self.height_steps_mm] if fit_height else []
        )

    def _refine(self, body, x, fitness, evaluator, optimizer, search, rng):
        """``passes`` times from ``x``: each step but the root searched alone over its whole
        joint range (``limb_evaluations`` each; arms raised to a boxer's guard lie far outside
        the box of a tracking step), then ``rounds`` full-pose searches; returns (pose,
        fitness, evaluations)."""
        used = 0
        for _ in range(self.passes):
            x, fitness, n = search_each_limb(
                search,
                body,
                x,
                fitness,
                evaluator,
                optimizer,
                self.limb_evaluations,
                rng,
                self.limb_samples,
                self.limb_restarts,
            )
            used += n
            for _ in range(self.rounds):
                x, fitness, n = search.estimate(body, x, evaluator, optimizer, self.evaluations, rng)
                used += n
            log.info("automatic start: limbs over their ranges, then the full pose -> fitness %.4f", fitness)
        return x, fitness, used

    def _try_shape(
        self, body, change: dict, x, fitness, cameras, masks, evaluator, optimizer, search, rng, keypoints=None
    ):
        """The body resized by ``change`` (``girth`` or ``height_mm``) with a short search
        from ``x`` (its root lifted or lowered so that the feet stay on the floor), scored
        with ``keypoints`` if given; it replaces ``body`` if its fitness is lower. Returns
        (pose, fitness, body, evaluations)."""
        value = float(np.clip(next(iter(change.values())), *(GIRTH_RANGE if "girth" in change else HEIGHT_RANGE_MM)))
        current = body.subject.girth if "girth" in change else body.subject.height_mm
        if value == current:
            return x, fitness, body, 0
        other = body.reshaped(**{next(iter(change)): value})
        start = x.copy()
        start[1] += other.floor_offset_mm - body.floor_offset_mm
        evaluator.setup(other, cameras, masks, keypoints)
        found, found_fitness, n = search.estimate(other, start, evaluator, optimizer, self.shape_evaluations, rng)
        log.info(
            "automatic start: %s %.3g -> fitness %.4f (%.4f before)", next(iter(change)), value, found_fitness, fitness
        )
        if found_fitness < fitness:
            return found, found_fitness, other, n
        return x, fitness, body, n
