"""The skin: the MakeHuman CC0 base mesh mapped onto the 16-joint skeleton.

Loads ``assets/makehuman`` (see its README for origin and licence), keeps the ``body``
group, converts decimetres to millimetres, moves the root joint to the origin and merges
the 31 CMU bones' skinning weights onto the 16 joints.  Joint pivots are the centroids of
the mesh's own joint cubes, as MakeHuman places its rig.
"""

from __future__ import annotations

import gzip
import json
import logging
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh

from mmocap.body.skeleton import JOINTS
from mmocap.errors import ConfigError
from mmocap.io import read_json_object

ASSETS = Path(__file__).parent / "assets" / "makehuman"
DM_TO_MM = 100.0

# Which of our 16 joints each CMU bone's weights go to.
BONE_TO_JOINT = {
    "Hips": "Root",
    "LHipJoint": "Root",
    "RHipJoint": "Root",
    "LowerBack": "BottomSpine",
    "Spine": "BottomSpine",
    "Spine1": "UpperSpine",
    "LeftShoulder": "UpperSpine",
    "RightShoulder": "UpperSpine",
    "Neck": "Neck",
    "Neck1": "Neck",
    "Head": "Neck",
    "LeftArm": "LShoulder",
    "LeftForeArm": "LElbow",
    "LeftHand": "LWrist",
    "LeftFingerBase": "LWrist",
    "LeftHandFinger1": "LWrist",
    "LThumb": "LWrist",
    "RightArm": "RShoulder",
    "RightForeArm": "RElbow",
    "RightHand": "RWrist",
    "RightFingerBase": "RWrist",
    "RightHandFinger1": "RWrist",
    "RThumb": "RWrist",
    "LeftUpLeg": "LHip",
    "LeftLeg": "LKnee",
    "LeftFoot": "LAnkle",
    "LeftToeBase": "LAnkle",
    "RightUpLeg": "RHip",
    "RightLeg": "RKnee",
    "RightFoot": "RAnkle",
    "RightToeBase": "RAnkle",
}
# The bone whose head is each joint's pivot.
PIVOT_BONE = {
    "Root": "Hips",
    "BottomSpine": "LowerBack",
    "UpperSpine": "Spine1",
    "Neck": "Neck",
    "LShoulder": "LeftArm",
    "LElbow": "LeftForeArm",
    "LWrist": "LeftHand",
    "RShoulder": "RightArm",
    "RElbow": "RightForeArm",
    "RWrist": "RightHand",
    "LHip": "LeftUpLeg",
    "LKnee": "LeftLeg",
    "LAnkle": "LeftFoot",
    "RHip": "RightUpLeg",
    "RKnee": "RightLeg",
    "RAnkle": "RightFoot",
}
# The far end of each joint's segment: (bone, 'head' | 'tail').
SEGMENT_END = {
    "Root": ("LowerBack", "head"),
    "BottomSpine": ("Spine1", "head"),
    "UpperSpine": ("Neck", "head"),
    "Neck": ("Head", "tail"),
    "LShoulder": ("LeftForeArm", "head"),
    "LElbow": ("LeftHand", "head"),
    "LWrist": ("LeftHandFinger1", "tail"),
    "RShoulder": ("RightForeArm", "head"),
    "RElbow": ("RightHand", "head"),
    "RWrist": ("RightHandFinger1", "tail"),
    "LHip": ("LeftLeg", "head"),
    "LKnee": ("LeftFoot", "head"),
    "LAnkle": ("LeftToeBase", "tail"),
    "RHip": ("RightLeg", "head"),
    "RKnee": ("RightFoot", "head"),
    "RAnkle": ("RightToeBase", "tail"),
}


@dataclass(frozen=True)
class SkinMesh:
    """A triangle mesh with per-vertex skinning weights over the 16 joints.

    Attributes:
        vertices: (V, 3) rest-pose positions in mm, root pivot at the origin.
        faces: (F, 3) int triangle indices, counter-clockwise seen from outside.
        weights: (V, 16) skinning weights, rows summing to 1.
        pivots: (16, 3) joint rest positions in mm.
        segment_ends: (16, 3) far end of each joint's body segment in mm.
    """

    vertices: np.ndarray
    faces: np.ndarray
    weights: np.ndarray
    pivots: np.ndarray
    segment_ends: np.ndarray

    @property
    def vertex_joint(self) -> np.ndarray:
        """(V,) the joint with the largest weight for each vertex."""
        return np.argmax(self.weights, axis=1)

    def trimesh(self) -> trimesh.Trimesh:
        """The rest mesh as a :class:`trimesh.Trimesh` (vertices in mm), unprocessed."""
        return trimesh.Trimesh(self.vertices, self.faces, process=False)

    def posed(self, skinning: np.ndarray) -> np.ndarray:
        """Linear blend skinning: (16, 4, 4) skinning transforms -> (V, 3) posed mm."""
        blended = np.einsum("vj,jab->vab", self.weights, skinning[:, :3, :])
        return np.einsum("vab,vb->va", blended[:, :, :3], self.vertices) + blended[:, :, 3]


def _read_obj(text: str) -> tuple[np.ndarray, dict[str, list[list[int]]]]:
    """Vertices (V, 3) and, per group name, its faces as lists of 0-based vertex indices."""
    groups: dict[str, list[list[int]]]
    vertices, groups, group = [], {}, None
    for line in text.splitlines():
        if line.startswith("v "):
            vertices.append(line.split()[1:4])
        elif line.startswith("g "):
            group = line.split()[1]
        elif line.startswith("f "):
            groups.setdefault(group, []).append([int(t.split("/")[0]) - 1 for t in line.split()[1:]])  # type: ignore[arg-type]  # after a "g" line
    return np.asarray(vertices, dtype=np.float64), groups


@lru_cache(maxsize=1)
def load_makehuman() -> SkinMesh:
    """The MakeHuman base mesh's ``body`` group, skinned onto the 16 joints (cached)."""
    with gzip.open(ASSETS / "base.obj.gz", "rt") as f:
        all_vertices, groups = _read_obj(f.read())
    with gzip.open(ASSETS / "weights.cmu_mb.json.gz", "rt") as f:
        bone_weights = json.load(f)["weights"]
    rig = read_json_object(ASSETS / "rig.cmu_mb.json")
    all_vertices = all_vertices * DM_TO_MM

    def cube_centre(bone: str, end: str) -> np.ndarray:
        cube = rig[bone][end]["cube_name"]
        idx = np.unique(np.concatenate(groups[cube]))
        return all_vertices[idx].mean(axis=0)

    pivots = np.stack([cube_centre(PIVOT_BONE[j], "head") for j in JOINTS])
    ends = np.stack([cube_centre(*SEGMENT_END[j]) for j in JOINTS])

    quads = groups["body"]
    used = np.unique(np.concatenate(quads))
    remap = -np.ones(len(all_vertices), dtype=np.int64)
    remap[used] = np.arange(len(used))
    triangles = []
    for poly in quads:  # fan triangulation keeps the winding
        for k in range(1, len(poly) - 1):
            triangles.append((poly[0], poly[k], poly[k + 1]))
    faces = remap[np.asarray(triangles)]

    weights = np.zeros((len(all_vertices), len(JOINTS)))
    for bone, pairs in bone_weights.items():
        j = JOINTS.index(BONE_TO_JOINT[bone])
        for v, w in pairs:
            weights[v, j] += w
    weights = weights[used]
    weights /= weights.sum(axis=1, keepdims=True)

    origin = pivots[0].copy()
    return SkinMesh(all_vertices[used] - origin, faces, weights, pivots - origin, ends - origin)


#: the standing heights (mm) and girths a subject may have
HEIGHT_RANGE_MM = (1000.0, 2300.0)
GIRTH_RANGE = (0.6, 1.6)


@dataclass(frozen=True)
class SubjectDimensions:
    """Body dimensions of one subject.

    Attributes:
        name: subject id, e.g. ``"S1"``.
        height_mm: standing height (top of head to sole) in mm.
        girth: scale of limb and trunk thickness relative to the base mesh (1 = as is).
    """

    name: str
    height_mm: float
    girth: float = 1.0

    def __post_init__(self):
        if not HEIGHT_RANGE_MM[0] <= self.height_mm <= HEIGHT_RANGE_MM[1]:
            raise ConfigError(
                f"subject {self.name}: height_mm must be in {list(HEIGHT_RANGE_MM)}, got {self.height_mm}"
            )
        if not GIRTH_RANGE[0] <= self.girth <= GIRTH_RANGE[1]:
            raise ConfigError(f"subject {self.name}: girth must be in {list(GIRTH_RANGE)}, got {self.girth}")


# S1-S3 are the synthetic generator's subjects; S4 completes HumanEva-I's four with a
# nominal build (S1's height, a little broader).  None is measured from the dataset.
SUBJECTS = {
    "S1": SubjectDimensions("S1", 1780.0, 1.00),
    "S2": SubjectDimensions("S2", 1720.0, 1.12),
    "S3": SubjectDimensions("S3", 1640.0, 0.90),
    "S4": SubjectDimensions("S4", 1780.0, 1.06),
}


def subject_dimensions(name: str) -> SubjectDimensions:
    """The :class:`SubjectDimensions` of the subject ``name`` (a key of ``SUBJECTS``); a
    ConfigError naming the known subjects otherwise."""
    try:
        return SUBJECTS[name]
    except KeyError:
        raise ConfigError(f"unknown subject '{name}'; known: {', '.join(SUBJECTS)}") from None


def _closest_on_segments(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(V, 3) points, (J, 3) segment starts and ends -> (V, J, 3) closest segment points."""
    ab = b - a
    t = np.einsum("vjk,jk->vj", points[:, None, :] - a[None], ab) / np.einsum("jk,jk->j", ab, ab)
    return a[None] + np.clip(t, 0, 1)[..., None] * ab[None]


def fit_subject(mesh: SkinMesh, subject: SubjectDimensions) -> SkinMesh:
    """The mesh scaled to the subject's height, with thickness scaled by ``girth``.

    Thickness is scaled across each joint's segment and blended by the skinning weights,
    so the surface stays smooth at the joints.
    """
    v, pivots, ends = mesh.vertices, mesh.pivots, mesh.segment_ends
    if subject.girth != 1.0:
        closest = _closest_on_segments(v, pivots, ends)
        moved = closest + subject.girth * (v[:, None, :] - closest)
        v = np.einsum("vj,vjk->vk", mesh.weights, moved)
    s = subject.height_mm / np.ptp(v[:, 1])
    return SkinMesh(v * s, mesh.faces, mesh.weights, pivots * s, ends * s)


@dataclass(frozen=True)
class SurfaceSamples:
    """Evenly spread points on the skin: the tracker's vertex model.

    Attributes:
        points: (N, 3) rest positions in mm, sorted by joint.
        normals: (N, 3) unit outward normals.
        joint: (N,) joint index of each point (largest interpolated weight).
        patch_mm: (16,) side in mm of a square with the area of a mean triangle of a mesh
            with these points as vertices (l_r of the Cano paper), per joint.
    """

    points: np.ndarray
    normals: np.ndarray
    joint: np.ndarray
    patch_mm: np.ndarray


def resample(mesh: SkinMesh, count: int | None, seed: int = 0) -> SurfaceSamples:
    """Evenly resample the skin to ``count`` points (None keeps the mesh's own vertices).

    Points come from area-weighted sampling thinned to a minimum spacing (trimesh's
    ``sample_surface_even``), the spacing chosen so that at least ``count`` survive; the
    surplus is dropped at random.  Normals and joints are interpolated barycentrically.
    """
    tm = mesh.trimesh()
    area = tm.area
    if count is None:
        points, normals, weights = mesh.vertices, tm.vertex_normals, mesh.weights
    else:
        if not 1000 <= count <= 200_000:
            raise ConfigError(f"body.vertices must be in [1000, 200000], got {count}")
        rng = np.random.default_rng(seed)
        radius = np.sqrt(area / count) * 0.6
        logging.getLogger("trimesh").setLevel(logging.ERROR)  # it logs every short draw
        for _ in range(30):
            pts, face_idx = trimesh.sample.sample_surface_even(tm, int(count * 1.3), radius=radius, seed=rng)
            if len(pts) >= count:
                break
            radius *= 0.93
        else:
            raise ConfigError(f"could not spread {count} points evenly over the body surface")
        keep = np.sort(rng.choice(len(pts), size=count, replace=False))
        points, face_idx = pts[keep], face_idx[keep]
        tri = tm.triangles[face_idx]
        bary = trimesh.triangles.points_to_barycentric(tri, points)
        corner = tm.faces[face_idx]
        normals = np.einsum("nc,nck->nk", bary, tm.vertex_normals[corner])
        weights = np.einsum("nc,ncj->nj", bary, mesh.weights[corner])
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    joint = np.argmax(weights, axis=1)
    order = np.argsort(joint, kind="stable")
    # A mesh on N well-spread vertices has about 2N triangles of area A / (2N) each.
    side = np.sqrt(area / (2 * len(points)))
    patch = np.full(len(JOINTS), side)
    return SurfaceSamples(points[order], normals[order], joint[order], patch)
