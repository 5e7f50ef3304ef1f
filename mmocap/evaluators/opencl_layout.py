"""The OpenCL kernel's memory layout, and the constants it is built with (pure NumPy).

This module is the one owner of the kernel's compile-time constants: :func:`build_options`
passes every one of them with ``-D`` (``kernels/silhouette.cl`` defines none itself and
stops with ``#error`` when one is missing), and the host code below lays out its arrays
with the same values.

Layout, for the kernel ``silhouette_counts``:

- vertices: each joint's vertices in blocks (:func:`block_size`) with similar normals, the
  joint's run padded to a multiple of the block size with zero-normal vertices (always culled),
  interleaved ``LANES`` vertices at a time (:func:`vertex_arrays`, :func:`interleaved`);
- one culling cone and bounding sphere per block (:func:`culling_cones`);
- per work-group its candidate's joint transforms in local memory, :data:`TRANSFORM_BYTES`
  per joint, and its cameras (:func:`views_per_group`);
- the model points of the keypoint term: (K,) int32 joint and (K, 3) float32 rest
  position (mm) each (:func:`point_arrays`), and per view their pixels, (K, 2) float32;
- bit masks, 1 bit per pixel (bit ``x % 32`` of word ``x // 32`` of a row), rows
  :func:`pitch` words apart (:func:`pack_bits`); in local memory the mask of a view or up to
  :data:`MAX_LAYERS` layers padded by :data:`PAD` px (:func:`layer_words`) and
  :data:`SINK_WORDS` after them.
"""

from __future__ import annotations

import functools

import numpy as np

from mmocap.bitmask import pack_rows
from mmocap.body.kinematics import KinematicChain
from mmocap.evaluators.silhouette import MAX_SIDE, NEAR_MM, vertex_table

#: px of padding on every side of a layer: a vertex centre further out cannot reach the image
PAD = 16
#: most padded layers (distinct patch sides of a view) in local memory
MAX_LAYERS = 4
#: bytes of local memory per joint for a candidate's transforms (12 float64 each)
TRANSFORM_BYTES = 96
#: mask and foreground rows start at multiples of this many 32-bit words
PITCH_WORDS = 8
#: words after the padded layers where the kernel's lanes without a centre in the layer set
#: their bits, one word per lane (LANES is at most 16), never read
SINK_WORDS = 16
#: the fewest and the most vertices per culling cone (:func:`block_size`); multiples of
#: every LANES
SMALLEST_BLOCK, LARGEST_BLOCK = 32, 128
#: bound on the float32 rounding of the culling test n . v + n . b, relative to
#: |n . v| + |b| (about 6 rounding errors of 2^-24 each: 3.6e-7)
ROUNDING = 1e-6


def count_words(local_size: int) -> int:
    """Output words a work-item counts at once (the kernel's COUNT_WORDS): 8 in vectors when
    one work-item does a whole view (CPUs), 1 when a work-group shares the rows."""
    return 8 if local_size == 1 else 1


@functools.cache  # once per population size: it is asked on every call
def views_per_group(local_size: int, cameras: int, candidates: int, compute_units: int) -> int:
    """Cameras per work-group (the kernel's ``views_per_group``) for a call of ``candidates``
    on a device of ``compute_units``; a work-group computes its candidate's joint transforms
    once for all its cameras.

    With ``local_size`` 1 (CPUs: a work-group is one work-item, a core runs one at a time):
    the most cameras per group with which the cores finish soonest, counting a group's
    time as its cameras' and the cores' rounds of groups as the work-groups over the compute
    units, rounded up: all cameras for a generation of CMA-ES on few cores (14 candidates on
    2: 7 rounds of 7 cameras, as 49 rounds of 1), so that the kinematics run once per
    candidate; fewer where the candidates are too few to keep every core busy (1 candidate:
    4 and 3 cameras on 2 cores), the kinematics then repeated per group (they take about
    a thirtieth of a view's time). Otherwise (GPUs) 1: more work-groups to spread over the
    compute units, and one work-item's serial kinematics makes the group's other work-items
    wait once per view, not once per camera group."""
    if local_size != 1:
        return 1
    options = {-(-cameras // groups) for groups in range(1, cameras + 1)}  # distinct group sizes

    def finish(views: int) -> int:
        return -(-candidates * -(-cameras // views) // compute_units) * views

    return min(sorted(options, reverse=True), key=finish)


def block_size(vertices: int) -> int:
    """Vertices per culling cone (the kernel's BLOCK) for a body of ``vertices``: about 1 %
    of them as a power of two in [SMALLEST_BLOCK, LARGEST_BLOCK], the fastest in the
    benchmarks: small bodies gain from small blocks (less padding, fewer blocks with both
    faces), large ones from larger blocks."""
    return int(min(LARGEST_BLOCK, max(SMALLEST_BLOCK, 2 ** round(np.log2(max(vertices, 1) / 100)))))


def build_options(local_size: int, lanes: int, block: int) -> list[str]:
    """The kernel's build options for a work-group size, vector width and block size: every
    constant it uses, and correctly rounded float32 division and square root (the
    silhouette rule)."""
    constants = {
        "LOCAL_SIZE": local_size,
        "LANES": lanes,
        "COUNT_WORDS": count_words(local_size),
        "BLOCK": block,
        "PAD": PAD,
        "MAX_LAYERS": MAX_LAYERS,
        "PITCH_WORDS": PITCH_WORDS,
        "NEAR_MM": repr(NEAR_MM),
        "ROUNDING": repr(ROUNDING),
        "MAX_SIDE": MAX_SIDE,
    }
    return [f"-D{name}={value}" for name, value in constants.items()] + ["-cl-fp32-correctly-rounded-divide-sqrt"]


def pitch(width: int) -> int:
    """Words per row of a mask or foreground ``width`` px wide: its words rounded up to
    PITCH_WORDS."""
    return -(-((width + 31) // 32) // PITCH_WORDS) * PITCH_WORDS


def layer_words(cam, local_size: int) -> int:
    """Words of one padded layer of the kernel for a camera: (height + 2 PAD) rows of the
    row's words and one more, rounded up to a multiple of COUNT_WORDS."""
    count = count_words(local_size)
    return ((cam.width + 31) // 32 + count) // count * count * (cam.height + 2 * PAD)


def pack_bits(mask: np.ndarray, size: int, packed: np.ndarray | None = None) -> np.ndarray:
    """(H, W) bool -> (size,) uint32: the rows of :func:`~mmocap.bitmask.pack_rows`
    (``packed`` if given), each widened with zeros to :func:`pitch` words, then zeros."""
    rows = pack_rows(mask) if packed is None else packed
    H, W = np.shape(mask)
    out = np.zeros(size, np.uint32)
    out[: H * pitch(W)].reshape(H, -1)[:, : rows.shape[1]] = rows
    return out


def point_arrays(joint: np.ndarray, rest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The model points for the kernel: (K,) joint indices -> (K,) int32, and (K, 3) rest
    positions (mm) -> (K, 3) float32, rounded once, as
    :func:`~mmocap.evaluators.silhouette.keypoint_pixels` rounds them."""
    return np.ascontiguousarray(joint, np.int32), np.ascontiguousarray(rest, np.float32).reshape(len(joint), 3)


def device_chain(body) -> KinematicChain | None:
    """The body's kinematic chain when the kernel can compute its transforms (``body.chain``
    a :class:`KinematicChain` of the body's joints), else None."""
    chain = getattr(body, "chain", None)
    if isinstance(chain, KinematicChain) and len(chain.rest_positions) == len(body.joint_rest_positions):
        return chain
    return None


def normal_blocks(normals: np.ndarray, index: np.ndarray, block: int) -> list[np.ndarray]:
    """``index`` reordered into blocks of ``block`` (the last maybe shorter) of similar
    normals: a k-d split of the (N, 3) unit ``normals`` at the median of the coordinate that
    spreads most, rounded to a multiple of ``block``, until a part fits in one block."""
    if len(index) <= block:
        return [index]
    spread = normals[index]
    axis = np.argmax(spread.max(axis=0) - spread.min(axis=0))
    index = index[np.argsort(spread[:, axis], kind="stable")]
    half = max(block, len(index) // 2 // block * block)
    return normal_blocks(normals, index[:half], block) + normal_blocks(normals, index[half:], block)


def vertex_arrays(body, patch_scale: float, block: int) -> tuple[np.ndarray, np.ndarray]:
    """The body's vertices for the kernel: (7, N4) float32
    :func:`~mmocap.evaluators.silhouette.vertex_table` (x, y, z (mm) inset by half a patch of
    ``patch_scale``, normal and n . v),
    sorted by joint, then in blocks of similar normals (see :func:`normal_blocks`, so that
    the blocks' culling cones are narrow); each joint's run padded to a multiple of ``block``
    with zero-normal vertices (always culled); (J + 1,) int32 first vertex of each joint,
    then N4."""
    joint = np.asarray(body.vertex_joint)
    J = len(body.joint_rest_positions)
    table = vertex_table(body, patch_scale)
    normals = table[3:6].T
    order = np.concatenate(
        [part for j in range(J) for part in normal_blocks(normals, np.flatnonzero(joint == j), block)]
    )
    sizes = np.bincount(joint, minlength=J)
    padded = (sizes + block - 1) // block * block
    start = np.r_[0, np.cumsum(padded)].astype(np.int32)
    slots = start[joint[order]] + (np.arange(len(order)) - np.r_[0, np.cumsum(sizes)][joint[order]])
    vertices = np.zeros((7, start[-1]), np.float32)
    vertices[:, slots] = table[:, order]
    return vertices, start


def interleaved(vertices: np.ndarray, lanes: int) -> np.ndarray:
    """(7, N4) :func:`vertex_arrays` -> (N4 / lanes, 7, lanes), the kernel's layout: the
    seven rows of each vector of ``lanes`` vertices side by side (faster than seven arrays:
    one vector's rows are read together)."""
    return np.ascontiguousarray(vertices.reshape(7, -1, lanes).transpose(1, 0, 2))


def culling_cones(vertices: np.ndarray, block: int) -> np.ndarray:
    """(N4 / block, 10) float64 per block of ``block`` vertices of :func:`vertex_arrays`: unit
    axis a (3) and cos, sin of the half-angle of a cone holding the block's normals, the
    centre c (3, mm) and radius r (mm) of a sphere holding its positions, and 1 for a block
    without padding (else 0).

    Every vertex of a block is a back face when ``(a . d) cos - |a x d| sin > r`` for
    ``d = c + R^T t`` (then ``n . (v + R^T t) >= n . d - r > 0`` for each of its normals n and
    positions v), and every vertex faces the camera when the largest ``n . d`` over the cone
    plus r is negative; the kernel tests both once per block, and skips the block or the
    per-vertex culling test. Padding is never facing, so only padding-free blocks take the
    second shortcut. A block whose normals span a half space or more, or that holds only
    padding, gets r = +inf (never skipped) or -inf (always skipped, as every padding vertex
    is culled) respectively.

    Cone and sphere are widened a little, so that rounding cannot make a block test decide
    otherwise than the per-vertex test would: r by ``ROUNDING (2 |c| + r)`` here and by
    ``ROUNDING |d|`` in the kernel, which bounds the float32 rounding of the per-vertex
    ``n . v + n . b`` (at most ``ROUNDING (|v| + |b|)``, with ``|v| <= |c| + r`` and
    ``|b| <= |d| + |c|``)."""
    vertices = np.asarray(vertices, np.float64)
    blocks = vertices.shape[1] // block
    points = vertices[:3].T.reshape(blocks, block, 3)
    normals = vertices[3:6].T.reshape(blocks, block, 3)
    real = np.any(normals != 0, axis=2)  # (blocks, block)
    count = real.sum(axis=1)
    mean = normals.sum(axis=1)
    length = np.linalg.norm(mean, axis=1)
    axis = mean / np.where(length > 0, length, 1.0)[:, None]
    cos_to_axis = np.where(real, np.einsum("bka,ba->bk", normals, axis), 1.0)
    half_angle = np.arccos(np.clip(cos_to_axis.min(axis=1), -1.0, 1.0)) + 1e-6
    lo = np.where(real[..., None], points, np.inf).min(axis=1)
    hi = np.where(real[..., None], points, -np.inf).max(axis=1)
    with np.errstate(invalid="ignore"):  # inf - inf: padding only
        centre = np.where(count[:, None] > 0, 0.5 * (lo + hi), 0.0)
    radius = np.where(real, np.linalg.norm(points - centre[:, None], axis=2), 0.0).max(axis=1)
    radius = radius * (1 + 1e-9) + 1e-6
    radius += ROUNDING * (2 * np.linalg.norm(centre, axis=1) + radius)
    radius[half_angle >= np.pi / 2] = np.inf
    radius[count == 0] = -np.inf
    full = (count == block).astype(np.float64)
    return np.c_[axis, np.cos(half_angle), np.sin(half_angle), centre, radius, full]
