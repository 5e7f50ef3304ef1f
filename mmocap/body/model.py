"""Stage "model building": the tracker's body model for one subject.

Combines the skeleton (:mod:`mmocap.body.skeleton`), the subject-fitted MakeHuman skin
(:mod:`mmocap.body.mesh`) resampled to a vertex count, per-joint rest frames, and marker
points on the skin.  Units: mm and radians.
"""

from __future__ import annotations

import numpy as np

from mmocap.body import skeleton
from mmocap.body.kinematics import KinematicChain, global_transforms
from mmocap.body.mesh import (
    GIRTH_RANGE,
    HEIGHT_RANGE_MM,
    SkinMesh,
    SubjectDimensions,
    fit_subject,
    load_makehuman,
    resample,
    subject_dimensions,
)
from mmocap.body.skeleton import JOINTS
from mmocap.validate import check_number

ARM_JOINTS = ("LShoulder", "LElbow", "LWrist", "RShoulder", "RElbow", "RWrist")
FORWARD = np.array([0.0, 0.0, 1.0])


def rest_frames(mesh: SkinMesh) -> np.ndarray:
    """(16, 3, 3) joint rest frames; columns are the local x, y, z axes in model axes.

    Arm joints: x along the segment, y = x cross forward (so +Ry flexes the elbow and
    swings the arm forward on both sides), z completes the frame.  Other joints use the
    model axes, so +Rx flexes the knee and -Rx flexes the hip.
    """
    frames = np.tile(np.eye(3), (len(JOINTS), 1, 1))
    for name in ARM_JOINTS:
        j = JOINTS.index(name)
        x = mesh.segment_ends[j] - mesh.pivots[j]
        x /= np.linalg.norm(x)
        y = np.cross(x, FORWARD)
        y /= np.linalg.norm(y)
        frames[j] = np.stack([x, y, np.cross(x, y)], axis=1)
    return frames


# Markers: (name, joint near which to look, direction to maximise, search radius in mm).
# Each marker is the skin vertex within the radius of the joint's pivot that lies furthest
# along the direction (model axes: x left, y up, z forward), e.g. the lateral epicondyle.
MARKER_RULES = (
    ("head", "Neck", (0, 1, 0), 400),
    ("neck", "Neck", (0, 0, -1), 90),
    ("pelvis", "Root", (0, 0, -1), 120),
    ("l_shoulder", "LShoulder", (0, 1, 0), 90),
    ("l_elbow", "LElbow", (0, 0, -1), 60),
    ("l_wrist", "LWrist", (1, 0, 0), 50),
    ("r_shoulder", "RShoulder", (0, 1, 0), 90),
    ("r_elbow", "RElbow", (0, 0, -1), 60),
    ("r_wrist", "RWrist", (-1, 0, 0), 50),
    ("l_hip", "LHip", (1, 0, 0), 120),
    ("l_knee", "LKnee", (0, 0, 1), 80),
    ("l_ankle", "LAnkle", (1, 0, 0), 60),
    ("r_hip", "RHip", (-1, 0, 0), 120),
    ("r_knee", "RKnee", (0, 0, 1), 80),
    ("r_ankle", "RAnkle", (-1, 0, 0), 60),
)
MARKER_NAMES = tuple(rule[0] for rule in MARKER_RULES)


#: the least reach (mm) of a marker's search beyond the skin vertex nearest to its joint: a
#: body far taller or thicker than the presets, whose skin lies further from its joints than
#: a rule's radius, still has candidates (the presets have 19.7 mm or more to spare)
MARKER_SEARCH_MARGIN_MM = 15.0


def marker_vertices(mesh: SkinMesh) -> np.ndarray:
    """(15,) indices into ``mesh.vertices`` of the marker points of :data:`MARKER_RULES`: each
    the vertex furthest along the rule's direction among those within its radius of the
    joint's pivot, or within :data:`MARKER_SEARCH_MARGIN_MM` beyond the nearest vertex if
    that reaches further."""
    out = []
    for _, joint, direction, radius in MARKER_RULES:
        distance = np.linalg.norm(mesh.vertices - mesh.pivots[JOINTS.index(joint)], axis=1)
        near = np.flatnonzero(distance < max(radius, distance.min() + MARKER_SEARCH_MARGIN_MM))
        out.append(near[np.argmax(mesh.vertices[near] @ np.asarray(direction, float))])
    return np.asarray(out)


#: the skin sample counts ``body.vertices`` takes, lowest and highest
VERTICES_RANGE = (1000, 200_000)


def body_dimensions(subject: str, height_mm: float | None = None, girth: float | None = None) -> SubjectDimensions:
    """The preset ``subject`` (S1-S4) with its height (mm) and girth replaced where given;
    a ConfigError naming ``body.height_mm`` or ``body.girth`` if out of range."""
    preset = subject_dimensions(subject)
    if height_mm is not None:
        height_mm = check_number("body.height_mm", height_mm, *HEIGHT_RANGE_MM)
    if girth is not None:
        girth = check_number("body.girth", girth, *GIRTH_RANGE)
    return SubjectDimensions(
        preset.name,
        preset.height_mm if height_mm is None else float(height_mm),
        preset.girth if girth is None else float(girth),
    )


def check_body(subject, dof, vertices, seed, height_mm=None, girth=None) -> None:
    """ConfigError naming the ``body.*`` key of the first bad argument of :class:`BodyModel`
    (cheap: nothing is loaded)."""
    body_dimensions(subject, height_mm, girth)
    dof = check_number("body.dof", dof, 1, 51, integer=True)
    skeleton.dof_mask(dof)
    if vertices is not None:
        check_number("body.vertices", vertices, *VERTICES_RANGE, integer=True)
    check_number("body.seed", seed, 0, 2**32 - 1, integer=True)


class BodyModel:
    """The articulated body the tracker fits: skeleton, vertex-sampled skin and markers.

    Args:
        subject: the preset body (``"S1"``, ``"S2"``, ``"S3"``, ``"S4"``: height and girth).
        height_mm: the subject's standing height in mm, top of the head to the soles (None =
            the preset's).
        girth: thickness of limbs and trunk relative to the base mesh (1 = as is; None = the
            preset's).
        dof: 39 (Table 1), 28 (its reduction) or 51 (every axis).
        vertices: skin sample count, evenly spread (Cano's levels: ``scale.meshes`` of
            ``conf/scale/paper.yaml``; the default is the smallest); None keeps the mesh's
            13 380 unevenly spaced vertices.
        seed: seed of the resampling.

    Attributes used by the evaluators: ``rest_vertices`` (N, 3) mm, ``rest_normals``
    (N, 3), ``vertex_joint`` (N,), ``joint_rest_positions`` (16, 3) mm, ``patch_mm``
    (16,) mm, :meth:`transforms` and ``chain``, the :class:`KinematicChain` that computes
    them (the OpenCL evaluator computes them on the device from it).
    """

    def __init__(
        self,
        subject: str = "S1",
        dof: int = 39,
        vertices: int | None = 13695,
        seed: int = 0,
        height_mm: float | None = None,
        girth: float | None = None,
    ):
        check_body(subject, dof, vertices, seed, height_mm, girth)
        self.subject = body_dimensions(subject, height_mm, girth)
        self.vertices_requested, self.seed = vertices, seed
        self.dof = int(dof)
        self.mask = skeleton.dof_mask(self.dof)
        self.mesh = fit_subject(load_makehuman(), self.subject)
        samples = resample(self.mesh, vertices, seed)
        self.rest_vertices = samples.points
        self.rest_normals = samples.normals
        self.vertex_joint = samples.joint
        self.patch_mm = samples.patch_mm
        self.joint_rest_positions = self.mesh.pivots
        self.rest_frames = rest_frames(self.mesh)
        self.chain = KinematicChain(self.joint_rest_positions, self.rest_frames)
        marker_idx = marker_vertices(self.mesh)
        self.marker_names = MARKER_NAMES
        self.marker_rest = self.mesh.vertices[marker_idx]
        self.marker_joint = self.mesh.vertex_joint[marker_idx]
        self.lower, self.upper = skeleton.limits()

    def reshaped(self, height_mm: float | None = None, girth: float | None = None) -> BodyModel:
        """The same body (preset, DOF, skin samples) with another height (mm) or girth."""
        return BodyModel(
            self.subject.name,
            self.dof,
            self.vertices_requested,
            self.seed,
            self.subject.height_mm if height_mm is None else height_mm,
            self.subject.girth if girth is None else girth,
        )

    def resampled(self, vertices: int | None) -> BodyModel:
        """The same body (preset, shape, DOF, seed) with ``vertices`` skin samples."""
        return BodyModel(self.subject.name, self.dof, vertices, self.seed, self.subject.height_mm, self.subject.girth)

    @property
    def n_vertices(self) -> int:
        """N, the number of skin vertices the silhouettes are drawn from."""
        return len(self.rest_vertices)

    @property
    def floor_offset_mm(self) -> float:
        """Height of the root pivot above the soles in the rest pose, mm."""
        return float(-self.mesh.vertices[:, 1].min())

    def rest_pose(self) -> np.ndarray:
        """(51,) the A-pose standing on the floor at the world origin."""
        x = np.zeros(skeleton.N_FULL)
        x[1] = self.floor_offset_mm
        return x

    def clip(self, X: np.ndarray) -> np.ndarray:
        """Full poses clipped to the joint limits."""
        return np.clip(X, self.lower, self.upper)

    def global_transforms(self, X: np.ndarray) -> np.ndarray:
        """(n, 51) poses -> (n, 16, 4, 4) joint-to-world transforms."""
        return global_transforms(X, self.joint_rest_positions, self.rest_frames)

    def transforms(self, X: np.ndarray) -> np.ndarray:
        """(n, 51) poses -> (n, 16, 4, 4) skinning transforms (rest mm -> world mm), those of
        :attr:`chain`."""
        return self.chain.transforms(X)

    def joint_positions(self, X: np.ndarray) -> np.ndarray:
        """(n, 51) poses -> (n, 16, 3) joint positions in world mm."""
        return self.global_transforms(X)[..., :3, 3]

    def markers(self, X: np.ndarray) -> np.ndarray:
        """(n, 51) poses -> (n, 15, 3) marker positions in world mm (rigid per joint)."""
        S = self.transforms(X)[:, self.marker_joint]
        return np.einsum("nmab,mb->nma", S[..., :3, :3], self.marker_rest) + S[..., :3, 3]

    def posed_vertices(self, x: np.ndarray) -> np.ndarray:
        """(51,) pose -> (N, 3) sampled skin points in world mm (rigid per joint)."""
        S = self.transforms(x[None])[0][self.vertex_joint]
        return np.einsum("nab,nb->na", S[:, :3, :3], self.rest_vertices) + S[:, :3, 3]
