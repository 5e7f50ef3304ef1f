"""How far a synthetic sequence departs from what the tracker assumes (``realism=...``).

In the "exact" benchmark the tracker's body is the rendered body, the ground-truth markers
are the model's own skin points, the cameras are known exactly and every camera sees the
same instant. Real capture offers none of this. Each setting of :class:`Realism` adds one
departure, drawn once per sequence from the sequence's own seed (never from the search
seed), and zero turns it off:

======================== ============================================================
setting                  real-world counterpart
======================== ============================================================
``height_sd_mm``         the person's height differs from the tracker's body (the
                         subject preset, or a height measured with a tape): normal, mm
``girth_sd``             the person's build differs from the preset's girth: normal,
                         relative (0.05 = 5 %)
``marker_standoff_mm``   a mocap marker's centre sits above the skin (a 14 mm marker
                         on its base: about 9 mm), along the skin's normal
``marker_placement_sd_mm`` where a marker is stuck differs from the model's point: a
                         fixed offset per marker along the skin, normal per axis, mm
``rotation_sd_deg``      the calibration's error in each camera's orientation: a
                         rotation about a random axis, normal angle, degrees
``translation_sd_mm``    the calibration's error in each camera's position: normal per
                         axis, mm
``focal_sd``             the calibration's error in the focal length: normal, relative
``principal_point_sd_px`` the calibration's error in the principal point: normal per
                         axis, pixels
``sync_frames``          each camera's shutter is offset from the mocap clock by a
                         fixed time, uniform in +-``sync_frames`` frames
``camouflage``           clothing close to the background's colour: the person's colours
                         are pulled towards the scene's mean colour by this fraction
                         (0 = as drawn, 1 = the scene's colour)
``detector``             a 2-D keypoint detector run on the images, as Pose2Sim does: the
                         skeleton it writes (a name of
                         :data:`mmocap.data.skeletons.SKELETONS`, ``HALPE_26`` as
                         Pose2Sim's default); null writes no keypoint files, and the four
                         ``keypoint_*`` settings below are then unused
``keypoint_noise``       the detector's scatter about a joint, per frame: normal, as a
                         multiple of COCO's per-keypoint standard deviation of human
                         annotators (:data:`COCO_SIGMAS`, relative to the person's scale
                         in the image, the square root of the silhouette's area)
``keypoint_miss_rate``   the fraction of joints the detector misses in a frame
                         (written with confidence 0); joints outside the image are
                         missed as well
``keypoint_swap_rate``   left/right confusion: per frame, camera and left/right pair of
                         joints (the knees, ...), the chance that the two are swapped
``keypoint_offset_sd_mm`` where the detector puts a joint differs from the joint's centre:
                         a fixed offset per joint, drawn once per sequence, normal per
                         axis, mm, in the rest frame, added to the skeleton's own
                         definition offset (:data:`mmocap.data.skeletons.MAPPINGS`)
======================== ============================================================

The values of ``realistic`` and ``hard`` (``conf/realism/*.yaml``) and where they come from
are documented there. Lighting, sensor noise, lens distortion and the floor shadow are
the dataset's own settings (``conf/dataset/synthetic.yaml``) and are the same in every
realism level. What was drawn (true height and girth, each camera's calibration error and
time offset, the detector's offsets per joint and how many joints it missed and swapped)
is written to ``sequence.json`` under ``realism``; the tracker never reads it.

The simulated detector sees the true body (the rendered mesh's joint centres and nose) at
each camera's own time offset through the true camera, lens distortion included, so its
pixels are those of the raw image (:func:`detections`). Its confidences are drawn uniform
in :data:`SEEN_CONFIDENCE` for every joint it reports, swapped ones included (a detector
does not know it swapped them), and are 0 for missed joints. Its draws come from a stream
of their own (:func:`keypoint_rng`), so that turning the detector on leaves every image and
every other file of a sequence unchanged. Where the sizes of ``realistic`` and ``hard``
come from: the scatter is relative to COCO's per-keypoint sigmas (cocodataset.org,
keypoints-eval), so the hips scatter most and the nose least; the definition offsets are
sized after Needham et al. (Sci Rep 2021: 30-50 mm systematic differences at the hip and
knee, 1-15 mm at the ankle); the miss and swap rates, and the scatter's multiple, are
choices, kept below the roughly 25 % of keypoints with a localisation error (jitter,
left/right inversion, miss) that Ronchi & Perona (ICCV 2017) found on COCO.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from types import SimpleNamespace

import cv2
import numpy as np

from mmocap.body.keypoints import model_points
from mmocap.body.mesh import GIRTH_RANGE, HEIGHT_RANGE_MM, SkinMesh, SubjectDimensions
from mmocap.camera import Camera
from mmocap.data.skeletons import MAPPINGS, skeleton_joints
from mmocap.errors import ConfigError
from mmocap.validate import check_number

#: the largest value each setting may take (the smallest is 0)
#: the settings of the simulated detector: they change the keypoint files only
DETECTOR_SETTINGS = ("detector", "keypoint_noise", "keypoint_miss_rate", "keypoint_swap_rate", "keypoint_offset_sd_mm")

LIMITS = {
    "height_sd_mm": 200.0,
    "girth_sd": 0.3,
    "marker_standoff_mm": 50.0,
    "marker_placement_sd_mm": 100.0,
    "rotation_sd_deg": 5.0,
    "translation_sd_mm": 200.0,
    "focal_sd": 0.2,
    "principal_point_sd_px": 50.0,
    "sync_frames": 0.5,
    "camouflage": 1.0,
    "keypoint_noise": 10.0,
    "keypoint_miss_rate": 1.0,
    "keypoint_swap_rate": 1.0,
    "keypoint_offset_sd_mm": 100.0,
}

#: COCO's per-keypoint standard deviation of human annotators' clicks, relative to the
#: person's scale (the square root of the segment's area), by model point
#: (cocodataset.org/#keypoints-eval: sigma_i^2 = E[d_i^2 / s^2] over redundantly annotated
#: images; the constants of pycocotools). The neck and the pelvis (``Root``) are not COCO
#: keypoints: the neck takes the shoulders' value, the pelvis the hips'.
COCO_SIGMAS = {
    "Nose": 0.026,
    "Neck": 0.079,
    "LShoulder": 0.079,
    "RShoulder": 0.079,
    "LElbow": 0.072,
    "RElbow": 0.072,
    "LWrist": 0.062,
    "RWrist": 0.062,
    "Root": 0.107,
    "LHip": 0.107,
    "RHip": 0.107,
    "LKnee": 0.087,
    "RKnee": 0.087,
    "LAnkle": 0.089,
    "RAnkle": 0.089,
}

#: the range of confidences, uniform, that the simulated detector gives a joint it reports
#: (a choice, not a published distribution: high, above the 0.3 below which Pose2Sim's
#: triangulation ignores a joint, its likelihood_threshold_triangulation)
SEEN_CONFIDENCE = (0.7, 1.0)


@dataclass(frozen=True)
class Realism:
    """Departures of a synthetic sequence from the tracker's assumptions; see the module
    docstring for each field's unit and real-world counterpart. All zero is ``exact``."""

    name: str = "exact"
    height_sd_mm: float = 0.0
    girth_sd: float = 0.0
    marker_standoff_mm: float = 0.0
    marker_placement_sd_mm: float = 0.0
    rotation_sd_deg: float = 0.0
    translation_sd_mm: float = 0.0
    focal_sd: float = 0.0
    principal_point_sd_px: float = 0.0
    sync_frames: float = 0.0
    camouflage: float = 0.0
    detector: str | None = None
    keypoint_noise: float = 0.0
    keypoint_miss_rate: float = 0.0
    keypoint_swap_rate: float = 0.0
    keypoint_offset_sd_mm: float = 0.0

    @staticmethod
    def from_config(values) -> Realism:
        """A Realism from the ``realism`` config node (a mapping); ConfigError naming the
        first unknown key or bad value."""
        values = dict(values or {})
        known = {f.name for f in dataclasses.fields(Realism)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ConfigError(f"realism: unknown setting(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        name = values.get("name", "exact")
        if not isinstance(name, str):
            raise ConfigError(f"realism.name must be a name, got {name!r}")
        for key, high in LIMITS.items():
            if key in values:
                values[key] = check_number(f"realism.{key}", values[key], 0.0, high)
        detector = values.get("detector")
        if detector is not None:
            if not isinstance(detector, str):
                raise ConfigError(f"realism.detector must be a skeleton's name or null, got {detector!r}")
            try:
                skeleton_joints(detector)
            except ConfigError as exc:
                raise ConfigError(f"realism.detector: {exc}") from None
        return Realism(**values)

    def as_dict(self) -> dict:
        """Every setting by name (stored in the generator settings of sequence.json)."""
        return dataclasses.asdict(self)


#: every setting at zero: the control
EXACT = Realism()


def draw_rng(seed: int, subject: str, action: str) -> np.random.Generator:
    """The generator of a sequence's realism draws: its own stream, so that an ``exact``
    sequence is rendered exactly as without this module."""
    return np.random.default_rng([seed, sum(map(ord, subject)), sum(map(ord, action)), 1])


def true_dimensions(preset: SubjectDimensions, realism: Realism, rng: np.random.Generator) -> SubjectDimensions:
    """The rendered person's dimensions: the preset's, changed by the drawn differences
    (kept inside the model's height and girth ranges)."""
    height = preset.height_mm + realism.height_sd_mm * rng.standard_normal()
    girth = preset.girth * (1 + realism.girth_sd * rng.standard_normal())
    return SubjectDimensions(preset.name, float(np.clip(height, *HEIGHT_RANGE_MM)), float(np.clip(girth, *GIRTH_RANGE)))


def marker_offsets(mesh: SkinMesh, indices: np.ndarray, realism: Realism, rng: np.random.Generator) -> np.ndarray:
    """(M, 3) rest-pose offsets, mm, from the model's marker points ``mesh.vertices[indices]``
    to the markers' centres: the standoff along the skin's normal plus a placement offset
    in the skin's tangent plane."""
    normals = mesh.trimesh().vertex_normals[indices]
    placement = realism.marker_placement_sd_mm * rng.standard_normal((len(indices), 3))
    placement -= np.sum(placement * normals, axis=1, keepdims=True) * normals
    return realism.marker_standoff_mm * normals + placement


def posed_markers(mesh: SkinMesh, indices: np.ndarray, offsets: np.ndarray, skinning: np.ndarray) -> np.ndarray:
    """(n, M, 3) world positions, mm, of markers stuck at ``mesh.vertices[indices] + offsets``
    (rest pose, mm) that move with the skin, for skinning transforms (n, 16, 4, 4)."""
    stuck = SkinMesh(
        mesh.vertices[indices] + offsets, np.empty((0, 3), int), mesh.weights[indices], mesh.pivots, mesh.segment_ends
    )
    return np.stack([stuck.posed(S) for S in skinning])


def calibrated(camera: Camera, realism: Realism, rng: np.random.Generator) -> tuple[Camera, dict]:
    """The camera as a calibration would give it: rotation, position, focal length and
    principal point each off by a drawn error. Returns it and the errors drawn (degrees,
    mm, relative, pixels)."""
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    angle = np.deg2rad(realism.rotation_sd_deg) * rng.standard_normal()
    turn = cv2.Rodrigues(angle * axis)[0]
    centre_error = realism.translation_sd_mm * rng.standard_normal(3)
    focal_error = realism.focal_sd * rng.standard_normal()
    point_error = realism.principal_point_sd_px * rng.standard_normal(2)
    R = turn @ camera.R
    centre = -camera.R.T @ camera.t + centre_error
    K = camera.K.copy()
    K[0, 0] *= 1 + focal_error
    K[1, 1] *= 1 + focal_error
    K[:2, 2] += point_error
    seen = Camera(camera.name, K, camera.dist.copy(), R, -R @ centre, camera.width, camera.height, camera.colour)
    errors = {
        "rotation_deg": float(np.rad2deg(abs(angle))),
        "position_mm": float(np.linalg.norm(centre_error)),
        "focal": float(focal_error),
        "principal_point_px": point_error.tolist(),
    }
    return seen, errors


def reprojection_px(true: Camera, seen: Camera, points_mm: np.ndarray) -> float:
    """RMS distance, pixels, between the projections of world points (n, 3) mm through the
    true camera and through the calibrated one: what a calibration's reprojection check
    would show at the person."""
    return float(np.sqrt(np.mean(np.sum((true.project(points_mm) - seen.project(points_mm)) ** 2, axis=1))))


def time_offsets(cameras: int, realism: Realism, rng: np.random.Generator) -> np.ndarray:
    """(cameras,) each camera's shutter offset from the mocap clock, frames."""
    return rng.uniform(-realism.sync_frames, realism.sync_frames, cameras)


def poses_at(poses: np.ndarray, offset_frames: float) -> np.ndarray:
    """(n, 51) poses at frame times ``f + offset_frames`` from poses (n, 51) at frames f,
    interpolated linearly between neighbouring frames (extrapolated at the ends); for the
    sub-frame offsets of :func:`time_offsets`, where the angles change little."""
    if offset_frames == 0 or len(poses) < 2:
        return poses
    step = np.diff(poses, axis=0)
    step = np.concatenate([step, step[-1:]]) if offset_frames > 0 else np.concatenate([step[:1], step])
    return poses + offset_frames * step


def camouflaged(colours: np.ndarray, backgrounds: list[np.ndarray], amount: float) -> np.ndarray:
    """Face colours (F, 3) RGB in [0, 1] pulled by ``amount`` towards the mean colour of
    the background images (H, W, 3) uint8 BGR."""
    if amount == 0:
        return colours
    scene = np.mean([b.reshape(-1, 3).mean(axis=0) for b in backgrounds], axis=0)[::-1] / 255
    return (1 - amount) * colours + amount * scene


def keypoint_rng(seed: int, subject: str, action: str) -> np.random.Generator:
    """The generator of a sequence's simulated detections: a stream of its own, so that the
    detector leaves every other draw of the sequence (and so its images) as they were."""
    return np.random.default_rng([seed, sum(map(ord, subject)), sum(map(ord, action)), 2])


@dataclass(frozen=True)
class DetectorJoints:
    """The joints a simulated detector reports with a position: those of its skeleton that
    :data:`mmocap.data.skeletons.MAPPINGS` maps onto a model point (K of them).

    Attributes:
        skeleton: the skeleton's name (:data:`mmocap.data.skeletons.SKELETONS`, J joints).
        names: (K,) the mapped joints' names.
        index: (K,) int, each mapped joint's place in ``skeleton``.
        points: (K,) the model point of each (:data:`mmocap.body.keypoints.MODEL_POINTS`).
        offsets_mm: (K, 3) the drawn definition offsets, mm, rest frame (without the
            mapping's own).
        pairs: (P, 2) int, the left and right joint of each left/right pair, as indices
            into ``names``.
    """

    skeleton: str
    names: tuple[str, ...]
    index: np.ndarray
    points: tuple[str, ...]
    offsets_mm: np.ndarray
    pairs: np.ndarray

    def rest_offsets_mm(self) -> np.ndarray:
        """(K, 3) each joint's whole definition offset, mm: the mapping's plus the drawn."""
        mapping = MAPPINGS[self.skeleton]
        return np.array([mapping[name][1] for name in self.names], np.float64) + self.offsets_mm

    def sigmas(self) -> np.ndarray:
        """(K,) COCO's relative standard deviation of each joint (:data:`COCO_SIGMAS`)."""
        return np.array([COCO_SIGMAS[point] for point in self.points])


def detector_joints(skeleton: str, offset_sd_mm: float, rng: np.random.Generator) -> DetectorJoints:
    """The mapped joints of the skeleton named ``skeleton`` and their definition offsets,
    drawn once per sequence (normal per axis, ``offset_sd_mm``: the realism's
    ``keypoint_offset_sd_mm``)."""
    joints = skeleton_joints(skeleton)
    mapping = MAPPINGS[skeleton]
    names = tuple(name for name in joints if name in mapping)
    points = tuple(mapping[name][0] for name in names)
    offsets = offset_sd_mm * rng.standard_normal((len(names), 3))
    pairs = [
        (k, points.index("R" + point[1:]))
        for k, point in enumerate(points)
        if point.startswith("L") and "R" + point[1:] in points
    ]
    index = np.array([joints.index(name) for name in names])
    return DetectorJoints(skeleton, names, index, points, offsets, np.array(pairs, np.int64).reshape(-1, 2))


def posed_joints(mesh: SkinMesh, joints: DetectorJoints, skinning: np.ndarray) -> np.ndarray:
    """(n, K, 3) world positions, mm, of the detector's joints on the true body ``mesh``:
    each model point plus its whole definition offset in the rest frame, riding rigidly on
    its joint, for skinning transforms (n, 16, 4, 4) (those the mesh is rendered with)."""
    owner = SimpleNamespace(joint_rest_positions=mesh.pivots, mesh=mesh)
    joint, rest = model_points(owner, joints.points, joints.rest_offsets_mm())
    S = skinning[:, joint]
    return np.einsum("nkab,kb->nka", S[..., :3, :3], rest) + S[..., :3, 3]


def detections(
    camera: Camera, world_mm: np.ndarray, scale_px: np.ndarray, joints: DetectorJoints, realism: Realism, rng
) -> tuple[np.ndarray, dict]:
    """What the simulated detector reports in one camera's frames.

    Args:
        camera: the true camera (the raw image's pixels, lens distortion included).
        world_mm: (n, K, 3) the joints' world positions, mm (:func:`posed_joints`).
        scale_px: (n,) the person's scale in each frame, px: the square root of the
            silhouette's area, as COCO's object scale.
        joints: the detector's joints (:func:`detector_joints`).
        realism: ``keypoint_noise``, ``keypoint_swap_rate`` and ``keypoint_miss_rate``.
        rng: the detections' generator (:func:`keypoint_rng`).

    Returns:
        (n, J, 3) x, y (px) and confidence of every joint of the skeleton (0, 0, 0 where
        missed, outside the image, or not mapped), and the counts ``missed`` (drawn
        misses), ``outside`` (joints outside the image or behind the camera, not counted
        again as missed) and ``swapped`` (left/right pairs swapped).
    """
    n, k = world_mm.shape[:2]
    flat = world_mm.reshape(-1, 3)
    uv = camera.project(flat).reshape(n, k, 2)
    in_front = (camera.to_camera(flat)[:, 2] > 0).reshape(n, k)
    # COCO: sigma^2 = E[d^2 / s^2] of the 2-D distance d, so sigma * s / sqrt(2) per axis
    spread = realism.keypoint_noise * joints.sigmas()[None, :] * scale_px[:, None] / np.sqrt(2)
    uv = uv + spread[..., None] * rng.standard_normal((n, k, 2))
    swapped = rng.random((n, len(joints.pairs))) < realism.keypoint_swap_rate
    missed = rng.random((n, k)) < realism.keypoint_miss_rate
    confidence = rng.uniform(*SEEN_CONFIDENCE, (n, k))
    for p, (left, right) in enumerate(joints.pairs):
        rows = swapped[:, p]
        uv[rows, left], uv[rows, right] = uv[rows, right], uv[rows, left].copy()
    inside = in_front & np.all((uv >= 0) & (uv <= [camera.width - 1, camera.height - 1]), axis=2)
    seen = inside & ~missed
    found = np.zeros((n, len(skeleton_joints(joints.skeleton)), 3))
    found[:, joints.index, :2] = np.where(seen[..., None], uv, 0.0)
    found[:, joints.index, 2] = np.where(seen, confidence, 0.0)
    counts = {"missed": int(missed.sum()), "outside": int((~inside & ~missed).sum()), "swapped": int(swapped.sum())}
    return found, counts
