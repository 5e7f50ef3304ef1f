"""OpenCL evaluators: the rule of :mod:`mmocap.evaluators.silhouette` as a PyOpenCL kernel.

The host computes, once per body, the vertex arrays and culling cones
(:mod:`mmocap.evaluators.opencl_layout`). A call is, per device, one launch of the kernel
``silhouette_counts`` (``kernels/silhouette.cl``) and one read-back, with one wait. Each
work-group takes one candidate and a group of its cameras
(:func:`~mmocap.evaluators.opencl_layout.views_per_group`: on a CPU all of them unless the
candidates are too few to keep every core busy, on a GPU one) and first puts the
candidate's joint transforms in local memory: computed there from the joint angles'
cosines and sines in the chain's float64 order when the body has a
:class:`~mmocap.body.kinematics.KinematicChain` (``body.chain``, as ``BodyModel`` has; the
same bits, once per work-group, for a fraction of the time the transforms take on the
host), else the host's (``body.transforms``). Then it does its views one after the other:
steps 1-2 and the coefficients in the float64 order of ``view_geometry``, steps 3-6 in the
rule's float32 arithmetic, with one bit mask in local memory (1 bit per pixel: 46 080
bytes for 640x480, rows padded to 8 words), cleared and reused per view, so no two
work-groups ever write the same memory. The work-group size and the local memory are the
device's and the built kernel's limits. Masks larger than that local memory (a 1920x1080
mask needs 270 KB, a GPU has 32 to 64 KB) are rendered in horizontal bands of as many rows
as fit (:func:`mask_path`; ``mmocap list`` shows each device's path for a full-HD mask),
one work-group per candidate, camera group and band: each band stamps every patch clipped
to its rows (no halo: a patch's rows in the band are exactly those of the whole mask) and
counts them, and the host adds the bands' counts up, equal to those of the whole mask.
Only a mask whose single row does not fit is a ConfigError that says so. The foreground
masks are uploaded once per frame as bit masks and counted against with popcounts. With
the keypoint term (:meth:`~SilhouetteEvaluator.counts_and_pixels`), the same launch also
writes the pixels of the frame's model points (joint and rest position, uploaded when they
change), from the joint transforms it has at hand, after the counts in the same output
buffer: one read-back brings both. Only rendering reads the masks back, in a second copy.
The poses go in a buffer made and filled with the call (far quicker than a write into a
kept one, which PoCL runs as a command of its own), and the kernel's arguments are set
again only when the frame's buffers, the kept output buffers or the cameras per
work-group change. The per-block culling bounds need double precision (``cl_khr_fp64``):
PoCL on CPUs and current GPUs have it.

Self-check: every evaluator counts a fixed test scene (:func:`check_scene`: a ball in a
64x48 camera, in the middle, near a corner and half out of the image) on its devices and
with NumPy when it is made, once per process and configuration. A device runs only if the
counts are equal; with ``accept_inexact`` also if each is within :data:`TOLERANCE` of
NumPy's. The kernel asks for correctly rounded float32 division and square root, which
not every device advertises (Oclgrind and Intel's CPU runtime do not) and some honour all
the same: the check decides, not the flag. The outcome (:attr:`OpenCLEvaluator.check`) is
logged, recorded in the run's provenance and shown by ``mmocap list``.

Devices, contexts, programs and PoCL's settings are :mod:`mmocap.evaluators.opencl_devices`'
(``platform`` and ``device`` select a device as described there); pyopencl is imported when
an evaluator is made, not with this module, so that mmocap works without it:
:meth:`OpenCLEvaluator.unavailable` says why it cannot be used.

:class:`MultiDeviceEvaluator` (``evaluator=multidevice``) splits the population over
several devices of one or more platforms (PoCL and Intel's CPU runtime side by side, a GPU
and a CPU), or over PoCL sub-devices when the selection is one CPU device, in proportion to
each device's measured speed; every candidate is computed by the same kernel on one device,
so the counts are those of a single device.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from mmocap import provenance
from mmocap.body.kinematics import KinematicChain
from mmocap.body.skeleton import JOINTS
from mmocap.camera import Camera
from mmocap.errors import ConfigError
from mmocap.evaluators import opencl_devices
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.evaluators.opencl_devices import (
    compiled_vector_bits,
    context,
    platforms,
    program,
    pyopencl,
    select_device,
    select_platform,
    sub_devices,
)
from mmocap.evaluators.opencl_layout import (
    LARGEST_BLOCK,
    MAX_LAYERS,
    SINK_WORDS,
    TRANSFORM_BYTES,
    block_size,
    build_options,
    culling_cones,
    device_chain,
    interleaved,
    layer_words,
    pack_bits,
    pitch,
    point_arrays,
    vertex_arrays,
    views_per_group,
)
from mmocap.evaluators.silhouette import (
    PATCH_SCALE,
    SilhouetteEvaluator,
    body_transforms,
    camera_rows,
    joint_rows,
)

log = logging.getLogger(__name__)
# the kernel's argument that changes with every call: the poses (or the transforms)
_POSES_ARG = 3
#: with accept_inexact, the self-check accepts a device whose every count of the test scene
#: differs from NumPy's by at most this fraction of it, or 1 px
TOLERANCE = 0.01
#: candidates per call and calls per device with which :meth:`MultiDeviceEvaluator.measure`
#: times each device
SPEED_CANDIDATES = 16
SPEED_REPEATS = 3
#: the mask size (width, height px) whose rendering path ``mmocap list`` shows per device
FULL_HD = (1920, 1080)
# (evaluator class, devices, patch_scale, (local_size, lanes) per device) -> the test
# scene's counts on the devices and with NumPy, (2, 3, 1) int64 each
_CHECKED: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}


def band_rows(width: int, local_bytes: int) -> int:
    """Rows of a ``width`` px wide mask that one band holds in ``local_bytes`` of local
    memory: rows of :func:`~mmocap.evaluators.opencl_layout.pitch` words and the spare word,
    rounded up to 8 words (the kernel reads the mask 8 words at a time); 0 if no row fits."""
    return max(0, (local_bytes // 4 - 8) // pitch(width))


def mask_path(width: int, height: int, local_bytes: int) -> str:
    """How the kernel renders a ``width`` x ``height`` px mask with ``local_bytes`` of local
    memory: ``"whole"`` (a view's mask at once), ``"in b bands of r rows"`` or
    ``"refused"`` (not even one row fits)."""
    if pitch(width) * height + 8 <= local_bytes // 4:  # with the spare word, in whole uint8
        return "whole"
    rows = band_rows(width, local_bytes)
    return f"in {-(-height // rows)} bands of {rows} rows" if rows else "refused"


def default_lanes(device, ctx) -> int:
    """The kernel's vector width when none is given: on a CPU one vector register of floats
    as the kernel compiler targets (:func:`~mmocap.evaluators.opencl_devices.compiled_vector_bits`
    in ``ctx``; where it does not say, as the device reports): 16 with AVX-512, else 8
    (measured fastest); 4 on other devices."""
    if not device.type & pyopencl().device_type.CPU:
        return 4
    floats = compiled_vector_bits(ctx, device) // 32 or device.native_vector_width_float
    return 16 if floats >= 16 else 8


class _DeviceQueue:
    """One device with its command queue, program and per-frame buffers; ``simd_lanes`` is
    the kernel's vector width there (the evaluator's ``lanes``: vertices per vector)."""

    def __init__(self, device, ctx, local_size: int | None, lanes: int | None):
        cl = self.cl = pyopencl()
        if not device.endian_little:
            raise ConfigError(
                f"OpenCL device {device.name.strip()!r} is big-endian; the bit masks need a little-endian device"
            )
        if not device.double_fp_config:
            raise ConfigError(
                f"OpenCL device {device.name.strip()!r} has no double precision "
                "(cl_khr_fp64), which the kernel's culling bounds need"
            )
        largest = min(device.max_work_group_size, device.max_work_item_sizes[0])
        if local_size is None:
            local_size = 1 if device.type & cl.device_type.CPU else min(64, largest)
        if not 1 <= int(local_size) <= largest:
            raise ConfigError(f"local_size must be in [1, {largest}] on {device.name.strip()!r}, got {local_size}")
        if lanes is None:
            lanes = default_lanes(device, ctx)
        if lanes not in (4, 8, 16):
            raise ConfigError(
                f"lanes must be 4, 8 or 16 (or null: the CPU's vector width, 4 on other devices), got {lanes!r}"
            )
        self.device, self.ctx, self.local_size, self.simd_lanes = device, ctx, int(local_size), lanes
        self.queue = cl.CommandQueue(ctx, device)
        self.frame: dict = {}  # name -> pyopencl.Buffer
        self.batch: dict = {}  # name -> (bytes, pyopencl.Buffer)
        self.bound: dict = {}  # the kernel's key of its arguments, see stale
        self.uploads = 0  # calls of upload so far: the frame's buffers change with it
        # the kernel's chain argument for a body without one (then never read)
        self.no_chain = cl.Buffer(ctx, cl.mem_flags.READ_ONLY, 64)
        self.block = 0
        self.extra_options: tuple[str, ...] = ()  # see OpenCLEvaluator.build_with
        self.build(LARGEST_BLOCK)
        # the block size changes loop bounds only, not what the kernel needs of the device
        info = cl.kernel_work_group_info
        fits = self.kernel.get_work_group_info(info.WORK_GROUP_SIZE, device)
        if self.local_size > fits:
            raise ConfigError(
                f"local_size={self.local_size} is more than the kernel can run on "
                f"{device.name.strip()!r}; set local_size to at most {fits}"
            )
        #: bytes of local memory left for the masks and the joint transforms (:data:`TRANSFORM_BYTES`
        #: per joint): the device's less the kernel's own
        self.local_bytes = device.local_mem_size - self.kernel.get_work_group_info(info.LOCAL_MEM_SIZE, device)

    def build(self, block: int) -> None:
        """Take the kernel built for culling blocks of ``block`` vertices (once per process,
        context and options; see :func:`~mmocap.evaluators.opencl_layout.block_size`)."""
        if block != self.block:
            built = program(self.ctx, build_options(self.local_size, self.simd_lanes, block) + list(self.extra_options))
            self.kernel = self.cl.Kernel(built, "silhouette_counts")
            self.block = block
            self.bound = {}  # a new kernel has no arguments set (and may reuse the old one's handle)

    def upload(self, **arrays: np.ndarray) -> None:
        """Read-only buffers kept until replaced (per frame, or per body)."""
        cl = self.cl
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        self.frame.update({k: cl.Buffer(self.ctx, flags, hostbuf=np.ascontiguousarray(a)) for k, a in arrays.items()})
        self.uploads += 1

    def stale(self, kernel, key: tuple) -> bool:
        """Whether ``kernel``'s arguments must be set: ``key`` (the frame's :attr:`uploads`,
        the per-call buffers and the values the arguments name) differs from its last call's,
        which it becomes. Setting them costs about as much as a small copy, and building and
        comparing them one by one a good part of a call. The buffer that is new with every
        call is set by the caller either way."""
        if self.bound.get(kernel.int_ptr) == key:
            return False
        self.bound[kernel.int_ptr] = key
        return True

    def buffer(self, name: str, nbytes: int):
        """A per-call buffer of at least ``nbytes``, grown as needed."""
        size, buf = self.batch.get(name, (0, None))
        if size < nbytes:
            size = max(nbytes, 2 * size, 64)
            buf = self.cl.Buffer(self.ctx, self.cl.mem_flags.READ_WRITE, size)
            self.batch[name] = (size, buf)
        return buf


class OpenCLEvaluator(SilhouetteEvaluator):
    """The silhouette fitness on one OpenCL device.

    Args:
        patch_scale: factor on the body's per-joint patch size (Cano Eq. 4), > 0.
        platform: platform index, part of its name, or None (the first with a device).
        device: device index on that platform.
        local_size: work-items per work-group (a candidate and one or more of its cameras,
            see :func:`~mmocap.evaluators.opencl_layout.views_per_group`); None: 1 on a
            CPU, 64 on other devices.
        lanes: vertices per vector in the kernel, 4, 8 or 16; None: on a CPU the float
            vector width that its kernel compiler targets (16 with AVX-512, else 8; see
            :func:`default_lanes`), 4 on other devices. The counts do not
            depend on it.
        accept_inexact: also run on a device whose self-check counts are within
            :data:`TOLERANCE` of NumPy's instead of equal (see the module's doc).
        max_local_bytes: use at most this many bytes of local memory for the masks (None:
            all the device has); less makes masks that would fit be rendered in bands
            (:func:`mask_path`), with the same counts.

    Attributes:
        check: the self-check's outcome, ``"exact"`` or ``"within tolerance (largest
            difference d px)"``.
    """

    name = "opencl"

    @classmethod
    def unavailable(cls) -> str | None:
        """Why this evaluator cannot run here (pyopencl missing, no OpenCL device), with
        what to install; None when it can."""
        return opencl_devices.unavailable()

    def __init__(
        self,
        patch_scale: float = PATCH_SCALE,
        platform=None,
        device: int = 0,
        local_size: int | None = None,
        lanes: int | None = None,
        accept_inexact: bool = False,
        max_local_bytes: int | None = None,
    ):
        super().__init__(patch_scale)
        if max_local_bytes is not None and int(max_local_bytes) < 1:
            raise ConfigError(f"max_local_bytes must be a positive number of bytes or null, got {max_local_bytes!r}")
        self.max_local_bytes = None if max_local_bytes is None else int(max_local_bytes)
        self._device_queues = self._make_device_queues(platform, device, local_size, lanes)
        self._body_uploaded = None
        self._points_uploaded: tuple[np.ndarray, np.ndarray] | None = None
        self._chain: KinematicChain | None = None
        self._weights = np.array([queue.device.max_compute_units for queue in self._device_queues], float)
        self.check = self._self_check(bool(accept_inexact))

    def build_with(self, options: list[str]) -> None:
        """Build the kernel with these options added (``-DNAME=VALUE``) from the next
        :meth:`setup` on: a changed kernel to measure (:mod:`mmocap.bench.parts`), whose
        counts are then that kernel's, not the silhouette rule's."""
        for device_queue in self._device_queues:
            device_queue.extra_options = tuple(options)
            device_queue.block = 0  # built again by the next setup
        self._body_uploaded = None

    @property
    def where(self) -> str:
        """'device (platform), local_size k, lanes m' for each distinct device configuration."""
        return "; ".join(
            dict.fromkeys(
                f"{device_queue.device.name.strip()} ({device_queue.device.platform.name.strip()}), local_size "
                f"{device_queue.local_size}, lanes {device_queue.simd_lanes}"
                for device_queue in self._device_queues
            )
        )

    def _self_check(self, accept_inexact: bool) -> str:
        """Count :func:`check_scene` here and with NumPy (once per process and
        configuration); the outcome, also recorded in the provenance, or a ConfigError."""
        key = (type(self), self.where, self.patch_scale, self.max_local_bytes)
        if key not in _CHECKED:
            body, camera, foreground, X = check_scene()
            with NumpyEvaluator(self.patch_scale) as reference:
                reference.setup(body, [camera], [foreground])
                expected = np.stack(reference.counts(X))
            self.setup(body, [camera], [foreground])
            _CHECKED[key] = np.stack(self.counts(X)), expected
            self.close()
        got, expected = _CHECKED[key]
        worst = int(np.abs(got - expected).max())
        within = np.all(np.abs(got - expected) <= np.maximum(1, TOLERANCE * expected))
        if worst == 0:
            outcome = "exact"
        elif within and accept_inexact:
            outcome = f"within tolerance (largest difference {worst} px)"
            log.warning(
                "OpenCL device %s counts a test scene within %g %% of numpy, not exactly (accept_inexact)",
                self.where,
                100 * TOLERANCE,
            )
        else:
            change = (
                "set accept_inexact=true to run it within that tolerance"
                if within
                else "choose another device (platform, device) or evaluator=numpy"
            )
            raise ConfigError(
                f"OpenCL device {self.where} counts a test scene differently "
                f"from numpy (model pixels {got[0].ravel().tolist()}, numpy's "
                f"{expected[0].ravel().tolist()}; overlap {got[1].ravel().tolist()}"
                f", numpy's {expected[1].ravel().tolist()}), "
                f"{'within' if within else 'beyond'} the {100 * TOLERANCE:g} % of "
                f"accept_inexact: {change}"
            )
        provenance.record_device_check(self.where, outcome)
        return outcome

    def _make_device_queues(self, platform, device, local_size, lanes) -> list[_DeviceQueue]:
        dev = select_device(platform, device)
        log.info("OpenCL evaluator on %s (%s)", dev.name.strip(), dev.platform.name)
        return [_DeviceQueue(dev, context([dev]), local_size, lanes)]

    @property
    def owns_cores(self) -> bool:  # type: ignore[override]  # read-only, as Evaluator's
        """True on CPU devices (PoCL's threads use every core)."""
        cpu = pyopencl().device_type.CPU
        return any(device_queue.device.type & cpu for device_queue in self._device_queues)

    @property
    def bands(self) -> tuple[int, int]:
        """(bands per view, rows per band) of the masks set up now: (1, the tallest mask's
        rows) when every mask fits the local memory whole (see :func:`mask_path`)."""
        return self._bands, self._band_rows

    @property
    def devices(self) -> list:
        """The OpenCL devices the population is split over."""
        return [device_queue.device for device_queue in self._device_queues]

    def setup(self, body, cameras, foreground, keypoints=None) -> None:
        """As the base class; masks of the foreground stage (``ForegroundMask``) bring their
        rows packed in this evaluator's layout, which are uploaded without repacking."""
        given = foreground if isinstance(foreground, (list, tuple)) else []
        self._packed = [getattr(m, "packed", None) for m in given]
        super().setup(body, cameras, foreground, keypoints)

    def _prepare(self) -> None:
        # the body's arrays only when the body is another object than last frame's (making and
        # uploading them takes a while); a body is not modified in place
        if self._body_uploaded is not self.body:
            block = block_size(len(self.body.vertex_joint))
            vertices, start = vertex_arrays(self.body, self.patch_scale, block)
            cones = culling_cones(vertices, block)
            joints = joint_rows(self.body, self.patch_scale)
            for device_queue in self._device_queues:
                device_queue.build(block)
                device_queue.upload(
                    vertices=interleaved(vertices, device_queue.simd_lanes), start=start, cones=cones, joints=joints
                )
            self._chain = device_chain(self.body)
            if self._chain is not None:
                for device_queue in self._device_queues:
                    device_queue.upload(chain=self._chain.rows())
            self._body_uploaded = self.body
        # per camera: a mask with a spare word (see the kernel's stamp), rounded up to a
        # multiple of 8 words; in local memory that mask or as many padded layers (see PAD)
        # as fit, at most MAX_LAYERS
        mask = max(pitch(cam.width) * cam.height + 1 for cam in self.cameras)
        layer = max(
            layer_words(cam, device_queue.local_size) for cam in self.cameras for device_queue in self._device_queues
        )
        self._mask_words = (mask + 7) // 8 * 8
        # words of local memory for the masks, beside the candidate's joint transforms
        small = min(self._device_queues, key=lambda device_queue: device_queue.local_bytes)
        free = small.local_bytes - TRANSFORM_BYTES * len(self.body.joint_rest_positions)
        room = max(0, min(free, self.max_local_bytes or free)) // 4
        if self._mask_words <= room:
            self._bands, self._band_rows = 1, max(cam.height for cam in self.cameras)
            # layers and sink within the room rounded down to 8 words: rounded up, they still fit
            self._max_layers = min(MAX_LAYERS, (room // 8 * 8 - SINK_WORDS) // layer)
            self._local_words = (max(mask, self._max_layers * layer + SINK_WORDS) + 7) // 8 * 8
        else:  # bands of rows of the widest mask, stamped directly
            wide = max(self.cameras, key=lambda cam: cam.width)
            self._band_rows = band_rows(wide.width, 4 * room)
            if self._band_rows < 1:
                raise ConfigError(
                    f"a row of a {wide.width} px wide mask does not fit the {4 * room} bytes of "
                    f"OpenCL local memory of {small.device.name.strip()!r}: use narrower masks, a "
                    "device with more local memory (platform, device) or evaluator=numpy"
                )
            self._bands = -(-max(cam.height for cam in self.cameras) // self._band_rows)
            self._max_layers = 0
            self._local_words = pitch(wide.width) * self._band_rows + 8
            log.info("OpenCL masks in %d bands of %d rows", self._bands, self._band_rows)
        shapes = np.array(
            [(cam.width, cam.height, c * self._mask_words) for c, cam in enumerate(self.cameras)], np.int32
        )
        packed = self._packed or [None] * len(self.foreground)
        fg = np.concatenate([pack_bits(m, self._mask_words, p) for m, p in zip(self.foreground, packed)])
        cameras = camera_rows(self.cameras)
        for device_queue in self._device_queues:
            device_queue.upload(shapes=shapes, fg=fg, cameras=cameras)
        self._upload_points()

    def _upload_points(self) -> None:
        """The frame's model points (:func:`point_arrays`), when they differ from those on
        the devices."""
        if self.keypoints is None or not len(self._point_joint):
            return
        points = point_arrays(self._point_joint, self._point_rest)
        uploaded = self._points_uploaded
        if uploaded is None or not all(np.array_equal(a, b) for a, b in zip(points, uploaded)):
            for device_queue in self._device_queues:
                device_queue.upload(point_joint=points[0], point_rest=points[1])
            self._points_uploaded = points

    def _counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        counts, _, _ = self._run(X, write_masks=False)
        return counts[..., 0].astype(np.int64), counts[..., 1].astype(np.int64)

    def _counts_and_pixels(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The counts and the model points' pixels from one launch per device."""
        counts, _, pixels = self._run(X, write_masks=False, points=len(self._point_joint))
        return counts[..., 0].astype(np.int64), counts[..., 1].astype(np.int64), pixels

    def _render(self, x: np.ndarray, camera_index: int) -> np.ndarray:
        _, masks, _ = self._run(x[None], write_masks=True)
        cam = self.cameras[camera_index]
        words = masks[camera_index, : pitch(cam.width) * cam.height].reshape(cam.height, -1)
        bits = np.unpackbits(words.view(np.uint8), axis=1, bitorder="little")
        return bits[:, : cam.width].astype(bool)

    def _counting_arguments(
        self, device_queue: _DeviceQueue, views: int, out, img, write_masks: bool, points: int
    ) -> tuple:
        """``silhouette_counts``' arguments on ``device_queue`` for the frame set up now,
        ``views`` cameras per work-group, writing counts and the first ``points`` model
        points' pixels to ``out`` and masks to ``img`` (with ``write_masks``); the poses
        (None here) are per call."""
        f = device_queue.frame
        J = len(self.body.joint_rest_positions)
        point_joint, point_rest = (f["point_joint"], f["point_rest"]) if points else (out, out)
        return (
            f["vertices"],
            f["start"],
            f["cones"],
            None,
            f["chain"] if self._chain is not None else device_queue.no_chain,
            np.int32(self._chain is not None),
            pyopencl().LocalMemory(TRANSFORM_BYTES * J),
            f["cameras"],
            f["joints"],
            f["shapes"],
            f["fg"],
            np.int32(len(self.cameras)),
            np.int32(J),
            np.int32(views),
            pyopencl().LocalMemory(4 * self._local_words),
            np.int32(self._max_layers),
            out,
            np.int32(write_masks),
            np.int32(self._mask_words),
            img,
            np.int32(points),
            point_joint,
            point_rest,
            np.int32(self._bands),
            np.int32(self._band_rows),
        )

    def _run(self, X: np.ndarray, write_masks: bool, points: int = 0):
        """Counts (n, C, 2) int32; with ``write_masks``, masks (n * C, mask_words) uint32; and
        the pixels (n, C, points, 2) float32 of the frame's first ``points`` model points
        (:func:`~mmocap.evaluators.silhouette.keypoint_pixels`), none with 0. One launch per
        device, and one read-back of its counts and pixels (and one of the masks)."""
        cl = pyopencl()
        n, J, C = len(X), len(self.body.joint_rest_positions), len(self.cameras)
        if self._chain is not None:  # the kernel computes the transforms
            poses = self._chain.pose_rows(X)
        else:  # [R t] rows per joint
            poses = np.ascontiguousarray(body_transforms(self.body, X)[:, :, :3]).reshape(n, J * 12)
        masks = np.empty((n * C if write_masks else 1, self._mask_words), np.uint32)
        if len(self._device_queues) == 1:
            edges = [0, n]
        else:
            shares = np.r_[0, np.cumsum(self._weights)] / self._weights.sum()
            edges = np.round(shares * n).astype(int)
        events, outputs = [], []  # outputs: per device its counts, then its pixels, and the counts' size
        for device_queue, a, b in zip(self._device_queues, edges[:-1], edges[1:]):
            if a == b:
                continue
            nV = (b - a) * C
            # per view: its bands' counts, then its model points' pixels (float32 bits)
            output = np.empty(nV * 2 * (self._bands + points), np.int32)
            # a new buffer, filled as it is made: far quicker than an enqueued write into a
            # kept one, which PoCL runs as a command of its own
            given = cl.Buffer(device_queue.ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=poses[a:b])
            out = device_queue.buffer("out", output.nbytes)
            img = device_queue.buffer("masks", masks[a * C : b * C].nbytes if write_masks else 4)
            views = views_per_group(device_queue.local_size, C, b - a, device_queue.device.max_compute_units)
            if device_queue.stale(device_queue.kernel, (device_queue.uploads, out, img, write_masks, views, points)):
                device_queue.kernel.set_args(
                    *self._counting_arguments(device_queue, views, out, img, write_masks, points)
                )
            device_queue.kernel.set_arg(_POSES_ARG, given)
            groups = (b - a) * -(-C // views) * self._bands
            cl.enqueue_nd_range_kernel(
                device_queue.queue, device_queue.kernel, (groups * device_queue.local_size,), (device_queue.local_size,)
            )
            copies = [cl.enqueue_copy(device_queue.queue, output, out, is_blocking=False)]
            if write_masks:
                copies.append(cl.enqueue_copy(device_queue.queue, masks[a * C : b * C], img, is_blocking=False))
            events.append(copies)
            outputs.append((output, nV * 2 * self._bands))
        for copies in events:  # one wait per device: a wait may not mix contexts (platforms)
            cl.wait_for_events(copies)
        if len(outputs) == 1:
            output, size = outputs[0]
            counts, pixels = output[:size], output[size:]
        else:
            counts = np.concatenate([output[:size] for output, size in outputs])
            pixels = np.concatenate([output[size:] for output, size in outputs])
        counts = counts.reshape(n * C, self._bands, 2)
        counts = counts[:, 0] if self._bands == 1 else counts.sum(axis=1, dtype=np.int32)
        return counts.reshape(n, C, 2), masks, pixels.view(np.float32).reshape(n, C, points, 2)

    def close(self) -> None:
        for device_queue in self._device_queues:
            device_queue.frame = {}
        self._body_uploaded = None
        self._points_uploaded = None
        self._chain = None
        super().close()


class MultiDeviceEvaluator(OpenCLEvaluator):
    """The OpenCL evaluator with the population split over several devices.

    Args:
        patch_scale: factor on the body's per-joint patch size (Cano Eq. 4), > 0.
        platform: as for :class:`OpenCLEvaluator`, or a list of them: every device of each
            (one context and program build per platform).
        devices: device indices on that (one) platform, or None for all of them.
        sub_devices: when the selection is a single CPU device, split it into this many
            PoCL sub-devices (None: one per compute unit), each with its own queue.
        local_size, lanes, accept_inexact, max_local_bytes: as for :class:`OpenCLEvaluator`.

    Candidates go to the devices in proportion to their speed, measured on each frame's
    body, cameras and masks the first time a body is set up (:meth:`measure`): the best of
    :data:`SPEED_REPEATS` calls of :data:`SPEED_CANDIDATES` candidates per device, alone.
    """

    name = "multidevice"

    def __init__(
        self,
        patch_scale: float = PATCH_SCALE,
        platform=None,
        devices=None,
        sub_devices: int | None = None,
        local_size: int | None = None,
        lanes: int | None = None,
        accept_inexact: bool = False,
        max_local_bytes: int | None = None,
    ):
        self._sub_devices = sub_devices
        self._measured_body = None
        super().__init__(patch_scale, platform, devices, local_size, lanes, accept_inexact, max_local_bytes)

    def _make_device_queues(self, platform, devices, local_size, lanes) -> list[_DeviceQueue]:
        several = not isinstance(platform, (str, int, np.integer, type(None)))
        if several and devices is not None:
            raise ConfigError(
                "multidevice: devices picks devices of one platform; with a list of "
                "platforms every device of each is used (leave devices null)"
            )
        if several:
            chosen = [d for p in dict.fromkeys(select_platform(p) for p in platform) for d in p.get_devices()]
        elif devices is None:
            chosen = select_platform(platform).get_devices()
        else:
            chosen = [select_device(platform, d) for d in devices]
        if not chosen:
            raise ConfigError("multidevice: the device list is empty")
        if len(chosen) == 1 and chosen[0].type & pyopencl().device_type.CPU:
            count = self._sub_devices or chosen[0].max_compute_units
            chosen = sub_devices(chosen[0], count)
        log.info(
            "multidevice evaluator on %d devices: %s",
            len(chosen),
            ", ".join(f"{d.name.strip()} ({d.platform.name.strip()})" for d in chosen),
        )
        # devices of one platform share a context, hence one program build
        by_platform: dict = {}
        for d in chosen:
            by_platform.setdefault(d.platform.int_ptr, []).append(d)
        contexts = {key: context(group) for key, group in by_platform.items()}
        return [_DeviceQueue(d, contexts[d.platform.int_ptr], local_size, lanes) for d in chosen]

    def _measure_new_body(self, X: np.ndarray) -> None:
        """:meth:`measure` the devices on the first call with a new body."""
        if len(self._device_queues) > 1 and self._measured_body is not self.body:
            self.measure(X)
            self._measured_body = self.body

    def _counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self._measure_new_body(X)
        return super()._counts(X)

    def _counts_and_pixels(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        self._measure_new_body(X)
        return super()._counts_and_pixels(X)

    def measure(self, X: np.ndarray) -> np.ndarray:
        """Each device's speed on the frame set up now, alone: the inverse of its best time
        of :data:`SPEED_REPEATS` calls of :data:`SPEED_CANDIDATES` candidates (``X`` (n, P)
        repeated); sets and returns the shares of the population (summing to 1), logged."""
        X = np.resize(np.asarray(X, np.float64), (SPEED_CANDIDATES, X.shape[1]))
        seconds = []
        for k in range(len(self._device_queues)):
            self._weights = np.eye(len(self._device_queues))[k]
            self._run(X, write_masks=False)  # warm-up: the kernel's first launch on this device
            best = np.inf
            for _ in range(SPEED_REPEATS):
                start = time.perf_counter()
                self._run(X, write_masks=False)
                best = min(best, time.perf_counter() - start)
            seconds.append(best)
        speed = 1.0 / np.maximum(seconds, 1e-9)
        self._weights = speed / speed.sum()
        log.info(
            "multidevice shares by measured speed: %s",
            ", ".join(
                f"{device_queue.device.name.strip()} ({device_queue.device.platform.name.strip()}) {share:.2f}"
                for device_queue, share in zip(self._device_queues, self._weights)
            ),
        )
        return self._weights


def device_checks() -> list[str]:
    """One line per OpenCL device: the self-check's outcome with the default settings, or
    why the evaluator cannot run there; none when OpenCL is unavailable."""
    if opencl_devices.unavailable():
        return []
    lines = []
    for i, p in enumerate(platforms()):
        for k, d in enumerate(p.get_devices()):
            try:
                ev = OpenCLEvaluator(platform=i, device=k)
            except ConfigError as err:
                outcome = f"refused: {err}"
            else:
                # beside the skeleton's joint transforms
                local_bytes = ev._device_queues[0].local_bytes - TRANSFORM_BYTES * len(JOINTS)
                outcome = (
                    f"self-check {ev.check}; {local_bytes} bytes of local memory for masks: "
                    f"{FULL_HD[0]}x{FULL_HD[1]} {mask_path(*FULL_HD, local_bytes)}"
                )
            lines.append(f"[{i}] {p.name.strip()}: [{k}] {d.name.strip()}: {outcome}")
    return lines


class _Ball:
    """A ball of 300 vertices, radius 100 mm, on one joint; pose (3,): its centre in mm."""

    def __init__(self, count: int = 300, radius: float = 100.0):
        i = np.arange(count) + 0.5  # a Fibonacci sphere
        polar, azimuth = np.arccos(1 - 2 * i / count), np.pi * (1 + 5**0.5) * i
        self.rest_normals = np.stack(
            [np.sin(polar) * np.cos(azimuth), np.cos(polar), np.sin(polar) * np.sin(azimuth)], axis=1
        )
        self.rest_vertices = radius * self.rest_normals
        self.vertex_joint = np.zeros(count, int)
        self.joint_rest_positions = np.zeros((1, 3))
        self.patch_mm = np.array([radius * np.sqrt(2 * np.pi / count)])

    def transforms(self, X: np.ndarray) -> np.ndarray:
        X = np.atleast_2d(X)
        T = np.tile(np.eye(4), (len(X), 1, 1, 1))
        T[:, 0, :3, 3] = X[:, :3]
        return T


def check_scene():
    """The self-check's scene: a ball (body), a 64x48 camera 1 m away, a half-image (48, 64)
    bool foreground, and (3, 3) poses (mm) that put the ball in the middle, near a corner
    and half out of the image."""
    camera = Camera.look_at("self-check", (0, 0, -1000), (0, 0, 0), 200.0, 64, 48)
    foreground = np.zeros((48, 64), bool)
    foreground[:, :32] = True
    X = np.array([[0.0, 0.0, 0.0], [-60.0, 45.0, 20.0], [-130.0, 0.0, -30.0]])
    return _Ball(), camera, foreground, X
