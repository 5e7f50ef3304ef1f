"""OpenCL evaluators: the rule of :mod:`mmocap.evaluators.silhouette` as a PyOpenCL kernel.

The host computes, once per body, ``vertex_table``, and per call the body's joint
transforms (``body.transforms``), unless the body has a
:class:`~mmocap.body.kinematics.KinematicChain` (``body.chain``, as ``BodyModel`` has): then
the kernel ``joint_transforms`` computes them from the joint angles' cosines and sines in
the chain's float64 order: the same bits, and 13 us of host time per call of 14 poses
instead of about 200 (measured). The kernel ``silhouette_counts``
(``kernels/silhouette.cl``) does the rest: steps 1-2 and the coefficients in the float64
order of ``view_geometry``, steps 3-6 in the rule's float32 arithmetic, one work-group per
(candidate, camera) pair, each with its own bit mask in local memory (1 bit per pixel:
46 080 bytes for 640x480, rows padded to 8 words), so no two work-groups ever write the
same memory. The foreground masks are uploaded once per frame as bit masks and counted
against with popcounts. The per-block
culling bounds need double precision (``cl_khr_fp64``): PoCL on CPUs and current GPUs
have it.

Devices: ``platform`` is an index into ``pyopencl.get_platforms()`` or a case-insensitive
part of a platform's name (``"portable"`` for PoCL, ``"nvidia"``), None for the first
platform that has a device; ``device`` is an index into that platform's devices. PoCL, the
CPU platform, comes from PyPI (``pocl-binary-distribution``), so a machine without any
system OpenCL driver still has one. No platform, or an index that does not exist, is a
:class:`~mmocap.errors.ConfigError` that lists what there is: there is no silent fallback.

Programs are built once per process and context (cached here). PoCL also keeps compiled
kernels on disk in ``POCL_CACHE_DIR``: this module points it at a private temporary folder
per process before OpenCL starts, so that parallel runs of a sweep never share one.
It also pins PoCL's worker threads to cores (``POCL_AFFINITY=1``) unless that variable is
already set. Both take effect only if this module is imported before anything else starts
OpenCL in the process.

:class:`MultiDeviceEvaluator` (``evaluator=multidevice``) splits the population over
several devices of a platform, or over PoCL sub-devices when the platform has one CPU
device; every (candidate, camera) pair is computed by the same kernel on one device, so
the counts are those of a single device.
"""
from __future__ import annotations

import atexit
import logging
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from mmocap.bitmask import pack_rows
from mmocap.body.kinematics import KinematicChain
from mmocap.errors import ConfigError
from mmocap.evaluators.silhouette import (
    MAX_SIDE,
    NEAR_MM,
    SilhouetteEvaluator,
    body_transforms,
    camera_rows,
    joint_rows,
    vertex_table,
)

log = logging.getLogger(__name__)
KERNEL = Path(__file__).with_name("kernels") / "silhouette.cl"
_PID_VAR = "MMOCAP_POCL_CACHE_PID"
_PAD = 16  # PAD of the kernel
_MAX_LAYERS = 4  # MAX_LAYERS of the kernel
_MAX_JOINTS = 32  # MAX_JOINTS of the kernel
_PITCH = 8  # the kernel's PITCH_WORDS: mask and foreground rows start at multiples of 8 words
_BLOCK = 128  # vertices per culling cone (the kernel's BLOCK): 3-4 % faster than 64, 1-2 % than 256
# bound on the float32 rounding of the culling test n . v + n . b, relative to |n . v| + |b|
# (about 6 rounding errors of 2^-24 each: 3.6e-7), the kernel's ROUNDING
_ROUNDING = 1e-6
# the kernels' arguments that change with every call: silhouette_counts' transforms and
# joint_transforms' poses
_TRANSFORMS_ARG, _POSES_ARG = 3, 0


def _private_pocl_cache() -> None:
    """Give this process its own POCL_CACHE_DIR (a child does not reuse its parent's)."""
    if os.environ.get(_PID_VAR) == str(os.getpid()):
        return
    folder = tempfile.mkdtemp(prefix="mmocap-pocl-")
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    os.environ["POCL_CACHE_DIR"] = folder
    os.environ[_PID_VAR] = str(os.getpid())


def _pin_pocl_threads() -> None:
    """Ask PoCL to pin its worker threads to one core each (``POCL_AFFINITY=1``) unless the
    environment says otherwise: CMA-ES frames on two cores took 1.08x as long with the
    threads free to move (measured, 27 393 vertices, 7 cameras)."""
    os.environ.setdefault("POCL_AFFINITY", "1")


_private_pocl_cache()
_pin_pocl_threads()
import pyopencl as cl  # noqa: E402  (after the PoCL variables are set)

_CONTEXTS: dict[tuple, cl.Context] = {}
_PROGRAMS: dict[tuple, cl.Program] = {}
_SUB_DEVICES: dict[tuple, list] = {}


def platforms() -> list:
    """The OpenCL platforms; ConfigError when there is none."""
    try:
        found = cl.get_platforms()
    except cl.Error as err:
        found, reason = [], str(err)
    else:
        reason = "the ICD loader lists none"
    if not found:
        raise ConfigError("no OpenCL platform found (" + reason + "): install "
                          "pocl-binary-distribution (CPU) or a GPU OpenCL driver, or choose "
                          "evaluator=numpy")
    return found


def describe(found) -> str:
    """'[0] PoCL: [0] cpu-name, ...' for an error message."""
    return "; ".join(f"[{i}] {p.name}: " + ", ".join(f"[{k}] {d.name.strip()}"
                                                      for k, d in enumerate(p.get_devices()))
                     for i, p in enumerate(found))


def select_platform(platform):
    """A platform by index, by part of its name, or (None) the first with a device."""
    found = platforms()
    if platform is None:
        for p in found:
            if p.get_devices():
                return p
        raise ConfigError(f"no OpenCL platform has a device ({describe(found)})")
    if isinstance(platform, (int, np.integer)) and not isinstance(platform, bool):
        if 0 <= platform < len(found):
            return found[platform]
        raise ConfigError(f"OpenCL platform index {platform} does not exist; there are "
                          f"{len(found)}: {describe(found)}")
    if isinstance(platform, str):
        match = [p for p in found if platform.lower() in p.name.lower()]
        if match:
            return match[0]
    raise ConfigError(f"no OpenCL platform matches platform={platform!r}; there are: "
                      f"{describe(found)}")


def select_device(platform, device):
    """One device of a platform (see :func:`select_platform`) by index."""
    p = select_platform(platform)
    devices = p.get_devices()
    if isinstance(device, bool) or not isinstance(device, (int, np.integer)):
        raise ConfigError(f"OpenCL device must be an index, got {device!r}")
    if not 0 <= device < len(devices):
        raise ConfigError(f"OpenCL device index {device} does not exist on platform "
                          f"{p.name!r}, which has {len(devices)}: {describe([p])}")
    return devices[device]


def context(devices) -> cl.Context:
    """The process's one context for this tuple of devices."""
    key = tuple(d.int_ptr for d in devices)
    if key not in _CONTEXTS:
        _CONTEXTS[key] = cl.Context(list(devices))
    return _CONTEXTS[key]


def program(ctx: cl.Context, local_size: int, lanes: int) -> cl.Program:
    """The kernel built for a context, work-group size and vector width, once per process."""
    key = (ctx.int_ptr, local_size, lanes)
    if key not in _PROGRAMS:
        options = [f"-DLOCAL_SIZE={local_size}", f"-DNEAR_MM={NEAR_MM!r}", f"-DBLOCK={_BLOCK}",
                   f"-DLANES={lanes}", f"-DCOUNT_WORDS={_count_words(local_size)}",
                   f"-DROUNDING={_ROUNDING!r}", f"-DMAX_SIDE={MAX_SIDE}",
                   "-cl-fp32-correctly-rounded-divide-sqrt"]
        _PROGRAMS[key] = cl.Program(ctx, KERNEL.read_text()).build(options=options)
    return _PROGRAMS[key]


def _count_words(local_size: int) -> int:
    """Output words a work-item counts at once (the kernel's COUNT_WORDS): 8 in vectors when
    one work-item does a whole view (CPUs), 1 when a work-group shares the rows."""
    return 8 if local_size == 1 else 1


def _pitch(width: int) -> int:
    """Words per row of a mask or foreground ``width`` px wide: its words rounded up to 8."""
    return -(-((width + 31) // 32) // _PITCH) * _PITCH


def _layer_words(cam, local_size: int) -> int:
    """Words of one padded layer of the kernel for a camera: (height + 2 PAD) rows of the
    row's words and one more, rounded up to a multiple of COUNT_WORDS."""
    count = _count_words(local_size)
    return ((cam.width + 31) // 32 + count) // count * count * (cam.height + 2 * _PAD)


def sub_devices(device, count: int) -> list:
    """``count`` sub-devices of equal compute units of a device (cached per process)."""
    key = (device.int_ptr, count)
    if key not in _SUB_DEVICES:
        units = device.max_compute_units
        if not 1 <= count <= units:
            raise ConfigError(f"cannot split OpenCL device {device.name.strip()!r} with {units} "
                              f"compute units into {count} sub-devices")
        parts = device.create_sub_devices([cl.device_partition_property.EQUALLY, units // count])
        _SUB_DEVICES[key] = parts[:count]
    return _SUB_DEVICES[key]


class _Lane:
    """One device with its queue, program and per-frame buffers."""

    def __init__(self, device, ctx: cl.Context, local_size: int | None, lanes: int | None):
        if not device.endian_little:
            raise ConfigError(f"OpenCL device {device.name.strip()!r} is big-endian; the bit "
                              "masks need a little-endian device")
        if not device.double_fp_config:
            raise ConfigError(f"OpenCL device {device.name.strip()!r} has no double precision "
                              "(cl_khr_fp64), which the kernel's culling bounds need")
        if not device.single_fp_config & cl.device_fp_config.CORRECTLY_ROUNDED_DIVIDE_SQRT:
            raise ConfigError(f"OpenCL device {device.name.strip()!r} cannot divide floats "
                              "correctly rounded, which the silhouette rule's float32 "
                              "projection needs to match the other backends")
        if local_size is None:
            local_size = 1 if device.type & cl.device_type.CPU else 64
        if not 1 <= int(local_size) <= device.max_work_group_size:
            raise ConfigError(f"local_size must be in [1, {device.max_work_group_size}] on "
                              f"{device.name.strip()!r}, got {local_size}")
        if lanes is None:  # 8 floats, one AVX2 register, measured fastest on CPUs
            lanes = 8 if device.type & cl.device_type.CPU else 4
        if lanes not in (4, 8, 16):
            raise ConfigError(f"lanes must be 4, 8 or 16 (or null: 8 on a CPU, 4 on other "
                              f"devices), got {lanes!r}")
        self.device, self.ctx, self.local_size, self.lanes = device, ctx, int(local_size), lanes
        self.queue = cl.CommandQueue(ctx, device)
        self.kernel = cl.Kernel(program(ctx, self.local_size, lanes), "silhouette_counts")
        self.kinematics = cl.Kernel(program(ctx, self.local_size, lanes), "joint_transforms")
        self.frame: dict[str, cl.Buffer] = {}
        self.batch: dict[str, tuple[int, cl.Buffer]] = {}
        self.bound: dict = {}  # each kernel's arguments, see bind

    def upload(self, **arrays: np.ndarray) -> None:
        """Read-only buffers kept until replaced (per frame, or per body)."""
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        self.frame.update({k: cl.Buffer(self.ctx, flags, hostbuf=np.ascontiguousarray(a))
                           for k, a in arrays.items()})

    def bind(self, kernel: cl.Kernel, *args) -> None:
        """Set a kernel's arguments unless they are its last call's (the same buffer objects,
        equal values): setting them costs about as much as a small copy. The buffer that is
        new with every call (None here) is set by the caller."""
        key = [a.size if isinstance(a, cl.LocalMemory) else a for a in args]
        bound = self.bound.get(kernel.int_ptr, [])
        if len(key) != len(bound) or not all(map(_same, key, bound)):
            kernel.set_args(*args)
            self.bound[kernel.int_ptr] = key

    def buffer(self, name: str, nbytes: int) -> cl.Buffer:
        """A per-call buffer of at least ``nbytes``, grown as needed."""
        size, buf = self.batch.get(name, (0, None))
        if size < nbytes:
            size = max(nbytes, 2 * size, 64)
            buf = cl.Buffer(self.ctx, cl.mem_flags.READ_WRITE, size)
            self.batch[name] = (size, buf)
        return buf


def _same(a, b) -> bool:
    """Identity for OpenCL buffers, equality for other kernel arguments."""
    if isinstance(a, cl.MemoryObject) or isinstance(b, cl.MemoryObject):
        return a is b
    return a == b


class OpenCLEvaluator(SilhouetteEvaluator):
    """The silhouette fitness on one OpenCL device.

    Args:
        patch_scale: factor on the body's per-joint patch size (Cano Eq. 4), > 0.
        platform: platform index, part of its name, or None (the first with a device).
        device: device index on that platform.
        local_size: work-items per (candidate, camera) work-group; None: 1 on a CPU, 64
            on other devices.
        lanes: vertices per vector in the kernel, 4, 8 or 16; None: 8 on a CPU, 4 on other
            devices. The counts do not depend on it.
    """

    def __init__(self, patch_scale: float = 1.0, platform=None, device: int = 0,
                 local_size: int | None = None, lanes: int | None = None):
        super().__init__(patch_scale)
        self._lanes = self._make_lanes(platform, device, local_size, lanes)
        self._body_uploaded = None
        self._chain: KinematicChain | None = None
        self._weights = np.array([lane.device.max_compute_units for lane in self._lanes], float)

    def _make_lanes(self, platform, device, local_size, lanes) -> list[_Lane]:
        dev = select_device(platform, device)
        log.info("OpenCL evaluator on %s (%s)", dev.name.strip(), dev.platform.name)
        return [_Lane(dev, context([dev]), local_size, lanes)]

    @property
    def owns_cores(self) -> bool:
        """True on CPU devices (PoCL's threads use every core)."""
        return any(lane.device.type & cl.device_type.CPU for lane in self._lanes)

    @property
    def devices(self) -> list:
        """The OpenCL devices the population is split over."""
        return [lane.device for lane in self._lanes]

    def setup(self, body, cameras, foreground) -> None:
        """As the base class; masks of the foreground stage (``ForegroundMask``) bring their
        rows packed in this evaluator's layout, which are uploaded without repacking."""
        given = foreground if isinstance(foreground, (list, tuple)) else []
        self._packed = [getattr(m, "packed", None) for m in given]
        super().setup(body, cameras, foreground)

    def _prepare(self) -> None:
        # the body's arrays only when the body is another object than last frame's (about
        # 30 ms for 27 393 vertices); a body is not modified in place
        if self._body_uploaded is not self.body:
            vertices, start = _vertex_arrays(self.body)
            cones = _culling_cones(vertices)
            joints = joint_rows(self.body, self.patch_scale)
            for lane in self._lanes:
                lane.upload(vertices=_interleaved(vertices, lane.lanes), start=start, cones=cones,
                            joints=joints)
            self._chain = _device_chain(self.body)
            if self._chain is not None:
                for lane in self._lanes:
                    lane.upload(chain=self._chain.rows())
            self._body_uploaded = self.body
        # per camera: a mask with a spare word (see the kernel's stamp), rounded up to a
        # multiple of 8 words; in local memory that mask or as many padded layers (see PAD)
        # as fit, at most _MAX_LAYERS
        mask = max(_pitch(cam.width) * cam.height + 1 for cam in self.cameras)
        layer = max(_layer_words(cam, lane.local_size)
                    for cam in self.cameras for lane in self._lanes)
        self._mask_words = (mask + 7) // 8 * 8
        # words of local memory, less 16 for the kernel's own __local ints
        room = min(lane.device.local_mem_size for lane in self._lanes) // 4 - 16
        if mask > room:
            raise ConfigError(f"a {max(cam.width for cam in self.cameras)} px wide mask needs "
                              f"{4 * mask} bytes of local memory; the OpenCL device has {4 * room}")
        self._max_layers = min(_MAX_LAYERS, room // layer)
        self._local_words = (max(mask, self._max_layers * layer) + 7) // 8 * 8
        shapes = np.array([(cam.width, cam.height, c * self._mask_words)
                           for c, cam in enumerate(self.cameras)], np.int32)
        packed = self._packed or [None] * len(self.foreground)
        fg = np.concatenate([_pack_bits(m, self._mask_words, p)
                             for m, p in zip(self.foreground, packed)])
        cameras = camera_rows(self.cameras)
        for lane in self._lanes:
            lane.upload(shapes=shapes, fg=fg, cameras=cameras)

    def _counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        counts, _ = self._run(X, write_masks=False)
        return counts[..., 0].astype(np.int64), counts[..., 1].astype(np.int64)

    def _render(self, x: np.ndarray, camera_index: int) -> np.ndarray:
        _, masks = self._run(x[None], write_masks=True)
        cam = self.cameras[camera_index]
        words = masks[camera_index, :_pitch(cam.width) * cam.height].reshape(cam.height, -1)
        bits = np.unpackbits(words.view(np.uint8), axis=1, bitorder="little")
        return bits[:, :cam.width].astype(bool)

    def _run(self, X: np.ndarray, write_masks: bool):
        """Counts (n, C, 2) int32 and, with ``write_masks``, masks (n * C, mask_words) uint32."""
        n, J, C = len(X), len(self.body.joint_rest_positions), len(self.cameras)
        if self._chain is not None:  # the transforms come from the joint_transforms kernel
            rows_in = self._chain.pose_rows(X)
        else:  # [R t] rows per joint
            rows_in = np.ascontiguousarray(body_transforms(self.body, X)[:, :, :3])
            rows_in = rows_in.reshape(n, J * 12)
        counts = np.empty((n * C, 2), np.int32)
        masks = np.empty((n * C if write_masks else 1, self._mask_words), np.uint32)
        if len(self._lanes) == 1:
            edges = [0, n]
        else:
            shares = np.r_[0, np.cumsum(self._weights)] / self._weights.sum()
            edges = np.round(shares * n).astype(int)
        events = []
        for lane, a, b in zip(self._lanes, edges[:-1], edges[1:]):
            if a == b:
                continue
            views = slice(a * C, b * C)
            nV = (b - a) * C
            # a new buffer, filled as it is made: about 1 us, where an enqueued write into a
            # kept one took 45 us (PoCL runs it as a command of its own)
            given = cl.Buffer(lane.ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                              hostbuf=rows_in[a:b])
            if self._chain is not None:
                rows = lane.buffer("transforms", (b - a) * J * 12 * 8)
                lane.bind(lane.kinematics, None, lane.frame["chain"], np.int32(b - a),
                          np.int32(J), rows)
                lane.kinematics.set_arg(_POSES_ARG, given)
                cl.enqueue_nd_range_kernel(lane.queue, lane.kinematics, (b - a,), (1,))
            else:
                rows = given
            out = lane.buffer("counts", counts[views].nbytes)
            img = lane.buffer("masks", masks[views].nbytes if write_masks else 4)
            f = lane.frame
            lane.bind(lane.kernel, f["vertices"], f["start"], f["cones"], None, f["cameras"],
                      f["joints"], f["shapes"], f["fg"],
                      np.int32(C), np.int32(J), cl.LocalMemory(4 * self._local_words),
                      np.int32(self._max_layers), out,
                      np.int32(write_masks), np.int32(self._mask_words), img)
            lane.kernel.set_arg(_TRANSFORMS_ARG, rows)
            cl.enqueue_nd_range_kernel(lane.queue, lane.kernel, (nV * lane.local_size,),
                                       (lane.local_size,))
            events.append(cl.enqueue_copy(lane.queue, counts[views], out, is_blocking=False))
            if write_masks:
                events.append(cl.enqueue_copy(lane.queue, masks[views], img, is_blocking=False))
        cl.wait_for_events(events)
        return counts.reshape(n, C, 2), masks

    def close(self) -> None:
        for lane in self._lanes:
            lane.frame = {}
        self._body_uploaded = None
        self._chain = None
        super().close()


class MultiDeviceEvaluator(OpenCLEvaluator):
    """The OpenCL evaluator with the population split over several devices.

    Args:
        patch_scale: factor on the body's per-joint patch size (Cano Eq. 4), > 0.
        platform: as for :class:`OpenCLEvaluator`.
        devices: device indices on that platform, or None for all of them.
        sub_devices: when the selection is a single CPU device, split it into this many
            PoCL sub-devices (None: one per compute unit), each with its own queue.
        local_size, lanes: as for :class:`OpenCLEvaluator`.

    Candidates go to the devices in proportion to their compute units.
    """

    def __init__(self, patch_scale: float = 1.0, platform=None, devices=None,
                 sub_devices: int | None = None, local_size: int | None = None,
                 lanes: int | None = None):
        self._sub_devices = sub_devices
        super().__init__(patch_scale, platform, devices, local_size, lanes)

    def _make_lanes(self, platform, devices, local_size, lanes) -> list[_Lane]:
        if devices is None:
            chosen = select_platform(platform).get_devices()
        else:
            chosen = [select_device(platform, d) for d in devices]
        if not chosen:
            raise ConfigError("multidevice: the device list is empty")
        if len(chosen) == 1 and chosen[0].type & cl.device_type.CPU:
            count = self._sub_devices or chosen[0].max_compute_units
            chosen = sub_devices(chosen[0], count)
        log.info("multidevice evaluator on %d devices: %s", len(chosen),
                 ", ".join(d.name.strip() for d in chosen))
        # devices of one platform share a context, hence one program build
        ctx = context(chosen)
        return [_Lane(d, ctx, local_size, lanes) for d in chosen]


def _device_chain(body) -> KinematicChain | None:
    """The body's kinematic chain when the kernel can compute its transforms (``body.chain``
    a :class:`KinematicChain` of at most ``_MAX_JOINTS`` joints), else None."""
    chain = getattr(body, "chain", None)
    joints = len(body.joint_rest_positions)
    if (isinstance(chain, KinematicChain) and len(chain.rest_positions) == joints
            and joints <= _MAX_JOINTS):
        return chain
    return None


def _normal_blocks(normals: np.ndarray, index: np.ndarray) -> list[np.ndarray]:
    """``index`` reordered into blocks of BLOCK (the last maybe shorter) of similar normals:
    a k-d split of the (N, 3) unit ``normals`` at the median of the coordinate that spreads
    most, rounded to a multiple of BLOCK, until a part fits in one block."""
    if len(index) <= _BLOCK:
        return [index]
    spread = normals[index]
    axis = np.argmax(spread.max(axis=0) - spread.min(axis=0))
    index = index[np.argsort(spread[:, axis], kind="stable")]
    half = max(_BLOCK, len(index) // 2 // _BLOCK * _BLOCK)
    return _normal_blocks(normals, index[:half]) + _normal_blocks(normals, index[half:])


def _vertex_arrays(body) -> tuple[np.ndarray, np.ndarray]:
    """The body's vertices for the kernel: (7, N4) float32 :func:`vertex_table` (rest x, y, z
    (mm), normal and n . v), sorted by joint, then in blocks of similar normals (see :func:`_normal_blocks`,
    so that the blocks' culling cones are narrow); each joint's run padded to a multiple
    of the kernel's BLOCK with zero-normal vertices (always culled); (J + 1,) int32 first
    vertex of each joint, then N4."""
    joint = np.asarray(body.vertex_joint)
    J = len(body.joint_rest_positions)
    table = vertex_table(body)
    normals = table[3:6].T
    order = np.concatenate([block for j in range(J)
                            for block in _normal_blocks(normals, np.flatnonzero(joint == j))])
    sizes = np.bincount(joint, minlength=J)
    padded = (sizes + _BLOCK - 1) // _BLOCK * _BLOCK
    start = np.r_[0, np.cumsum(padded)].astype(np.int32)
    slots = start[joint[order]] + (np.arange(len(order)) - np.r_[0, np.cumsum(sizes)][joint[order]])
    vertices = np.zeros((7, start[-1]), np.float32)
    vertices[:, slots] = table[:, order]
    return vertices, start


def _interleaved(vertices: np.ndarray, lanes: int) -> np.ndarray:
    """(7, N4) :func:`_vertex_arrays` -> (N4 / lanes, 7, lanes), the kernel's layout: the seven
    rows of each vector of ``lanes`` vertices side by side (3-4 % faster than seven arrays)."""
    return np.ascontiguousarray(vertices.reshape(7, -1, lanes).transpose(1, 0, 2))


def _culling_cones(vertices: np.ndarray) -> np.ndarray:
    """(N4 / BLOCK, 10) float64 per block of BLOCK vertices of :func:`_vertex_arrays`: unit
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
    otherwise than the per-vertex test would: r by ``_ROUNDING (2 |c| + r)`` here and by
    ``_ROUNDING |d|`` in the kernel, which bounds the float32 rounding of the per-vertex
    ``n . v + n . b`` (at most ``_ROUNDING (|v| + |b|)``, with ``|v| <= |c| + r`` and
    ``|b| <= |d| + |c|``)."""
    vertices = np.asarray(vertices, np.float64)
    blocks = vertices.shape[1] // _BLOCK
    points = vertices[:3].T.reshape(blocks, _BLOCK, 3)
    normals = vertices[3:6].T.reshape(blocks, _BLOCK, 3)
    real = np.any(normals != 0, axis=2)                                   # (blocks, BLOCK)
    count = real.sum(axis=1)
    mean = normals.sum(axis=1)
    length = np.linalg.norm(mean, axis=1)
    axis = mean / np.where(length > 0, length, 1.0)[:, None]
    cos_to_axis = np.where(real, np.einsum("bka,ba->bk", normals, axis), 1.0)
    half_angle = np.arccos(np.clip(cos_to_axis.min(axis=1), -1.0, 1.0)) + 1e-6
    lo = np.where(real[..., None], points, np.inf).min(axis=1)
    hi = np.where(real[..., None], points, -np.inf).max(axis=1)
    with np.errstate(invalid="ignore"):                                   # inf - inf: padding only
        centre = np.where(count[:, None] > 0, 0.5 * (lo + hi), 0.0)
    radius = np.where(real, np.linalg.norm(points - centre[:, None], axis=2), 0.0).max(axis=1)
    radius = radius * (1 + 1e-9) + 1e-6
    radius += _ROUNDING * (2 * np.linalg.norm(centre, axis=1) + radius)
    radius[half_angle >= np.pi / 2] = np.inf
    radius[count == 0] = -np.inf
    full = (count == _BLOCK).astype(np.float64)
    return np.c_[axis, np.cos(half_angle), np.sin(half_angle), centre, radius, full]


def _pack_bits(mask: np.ndarray, size: int, packed: np.ndarray | None = None) -> np.ndarray:
    """(H, W) bool -> (size,) uint32: the rows of :func:`pack_rows` (``packed`` if given),
    each widened with zeros to :func:`_pitch` words, then zeros."""
    rows = pack_rows(mask) if packed is None else packed
    H, W = np.shape(mask)
    out = np.zeros(size, np.uint32)
    out[:H * _pitch(W)].reshape(H, -1)[:, :rows.shape[1]] = rows
    return out
