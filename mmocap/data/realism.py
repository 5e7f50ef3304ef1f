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
======================== ============================================================

The values of ``realistic`` and ``hard`` (``conf/realism/*.yaml``) and where they come from
are documented there. Lighting, sensor noise, lens distortion and the floor shadow are
the dataset's own settings (``conf/dataset/synthetic.yaml``) and are the same in every
realism level. What was drawn (true height and girth, each camera's calibration error and
time offset) is written to ``sequence.json`` under ``realism``; the tracker never reads it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numpy as np

from mmocap.body.mesh import GIRTH_RANGE, HEIGHT_RANGE_MM, SkinMesh, SubjectDimensions
from mmocap.camera import Camera
from mmocap.errors import ConfigError
from mmocap.validate import check_number

#: the largest value each setting may take (the smallest is 0)
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
}


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
