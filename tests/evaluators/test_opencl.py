"""OpenCL evaluators: device selection, clear errors, the program cache, the multi-device split."""

import functools
import os
import re
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("pyopencl")
from mmocap.errors import ConfigError  # noqa: E402
from mmocap.evaluators import opencl, opencl_devices, opencl_layout  # noqa: E402
from mmocap.evaluators.silhouette import PATCH_SCALE  # noqa: E402
from mmocap.testing.evaluators import RIGS, BlobBody, masks, test_poses  # noqa: E402

try:
    opencl_devices.platforms()
except ConfigError:
    pytest.skip("no OpenCL platform on this machine", allow_module_level=True)


def run_python(code: str, **env) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env={**os.environ, **env}, timeout=120
    )


def test_no_platform_is_a_config_error_that_says_what_to_install():
    # an ICD vendor folder with no driver in it hides every platform, PoCL included
    done = run_python("from mmocap import registry\nregistry.make_evaluator('opencl')", OCL_ICD_VENDORS="/nonexistent")
    assert done.returncode != 0
    assert "ConfigError: evaluator 'opencl' is unavailable: no OpenCL platform found" in done.stderr
    assert "pocl-binary-distribution" in done.stderr


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"device": 99}, r"device index 99 does not exist on platform .*\[0\]"),
        ({"device": "first"}, r"device must be an index, got 'first'"),
        ({"platform": 42}, r"platform index 42 does not exist; there are \d+: \[0\]"),
        ({"platform": "no-such-vendor"}, r"no OpenCL platform matches platform='no-such-vendor'"),
        ({"local_size": 0}, r"local_size must be in \[1, \d+\]"),
        ({"lanes": 2}, r"lanes must be 4, 8 or 16 .*got 2"),
        ({"max_local_bytes": 0}, r"max_local_bytes must be a positive number of bytes or null, got 0"),
    ],
)
def test_bad_device_selection_names_the_value(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        opencl.OpenCLEvaluator(**kwargs)


def test_too_many_sub_devices_is_a_config_error():
    units = opencl_devices.select_device(None, 0).max_compute_units
    with pytest.raises(ConfigError, match=f"into {units + 1} sub-devices"):
        opencl.MultiDeviceEvaluator(sub_devices=units + 1)


def test_devices_with_a_list_of_platforms_is_a_config_error():
    with pytest.raises(ConfigError, match="with a list of platforms every device of each is used"):
        opencl.MultiDeviceEvaluator(platform=["portable"], devices=[0])


def test_a_list_of_one_platform_measures_its_devices_and_counts_as_one_device():
    multi = opencl.MultiDeviceEvaluator(platform=["portable"], sub_devices=2)
    body, cameras, foreground = BlobBody(), RIGS["front-side-near"], masks("front-side-near", "true")
    X = np.concatenate([test_poses()] * 4)
    with opencl.OpenCLEvaluator() as single:
        single.setup(body, cameras, foreground)
        expected = np.stack(single.counts(X))
    multi.setup(body, cameras, foreground)
    np.testing.assert_array_equal(np.stack(multi.counts(X)), expected)
    assert len(multi.devices) == 2
    assert multi._weights.sum() == pytest.approx(1)
    assert multi._weights.min() > 0
    multi.close()


def test_platform_by_name_and_program_built_once_per_process():
    name = opencl_devices.platforms()[0].name.split()[0].lower()
    a, b = opencl.OpenCLEvaluator(platform=name), opencl.OpenCLEvaluator(platform=0)
    assert a.devices == b.devices
    for ev in (a, b):  # one of them counted the small self-check body, in smaller blocks
        ev._device_queues[0].build(opencl_layout.LARGEST_BLOCK)
    assert a._device_queues[0].kernel.program.int_ptr == b._device_queues[0].kernel.program.int_ptr


def test_each_process_gets_its_own_pocl_cache_dir():
    parent = os.environ["POCL_CACHE_DIR"]
    assert os.path.isdir(parent)
    done = run_python(
        "import os\nfrom mmocap.evaluators import opencl_devices\n"
        "opencl_devices.platforms()\n"
        "print(os.environ['POCL_CACHE_DIR'])"
    )
    child = done.stdout.strip()
    assert done.returncode == 0
    assert child
    assert child != parent
    assert not os.path.exists(child)  # removed when the child exits


def counting_stale(stale, device_queue, served, kernel, key):
    """``device_queue.stale`` that counts the calls in which ``device_queue`` is given work."""
    served[id(device_queue)] += 1
    return stale(kernel, key)


@pytest.mark.parametrize("local_size", [1, 3, 32])
def test_multidevice_split_and_work_group_sizes_give_one_devices_counts(local_size):
    rig = "front-side-near"
    single = opencl.OpenCLEvaluator(local_size=1)
    multi = opencl.MultiDeviceEvaluator(local_size=local_size, sub_devices=2)  # a CPU: 2 sub-devices
    assert len(multi.devices) >= 2
    for ev in (single, multi):
        ev.setup(BlobBody(), RIGS[rig], masks(rig, "true"))
    X = test_poses()
    served = {id(device_queue): 0 for device_queue in multi._device_queues}
    for device_queue in multi._device_queues:  # count the candidates each device is given
        device_queue.stale = functools.partial(counting_stale, device_queue.stale, device_queue, served)
    for n in (1, 2, 3, len(X)):
        for got, expected in zip(multi.counts(X[:n]), single.counts(X[:n])):
            np.testing.assert_array_equal(got, expected)
    assert all(served.values()), f"a device was given no candidates: {served}"


@pytest.mark.parametrize("block", [32, 128])
def test_culling_cones_skip_only_back_faces_and_pass_only_front_faces(block):
    from mmocap.body.model import BodyModel

    vertices, _ = opencl_layout.vertex_arrays(BodyModel("S1", vertices=13695), PATCH_SCALE, block)
    cones = opencl_layout.culling_cones(vertices, block)
    rng = np.random.default_rng(0)
    # b = R^T t for cameras in every direction, 0.5 to 5 m from the joint's origin
    directions = rng.standard_normal((200, 3))
    bs = directions / np.linalg.norm(directions, axis=1, keepdims=True) * rng.uniform(500, 5000, (200, 1))
    blocks = vertices.shape[1] // block
    nx, ny, nz, nv = vertices[3:7]
    skipped_total = facing_total = 0
    for b in bs.astype(np.float32):
        d = cones[:, 5:8] + b
        ad = np.einsum("ka,ka->k", cones[:, :3], d)
        dlen = np.linalg.norm(d, axis=1)
        cross = np.sqrt(np.maximum(dlen**2 - ad * ad, 0.0))
        r = cones[:, 8] + opencl_layout.ROUNDING * dlen
        skipped = ad * cones[:, 3] - cross * cones[:, 4] > r
        # the kernel's float32 test, as the rule writes it
        facing = (nv + (nx * b[0] + ny * b[1] + nz * b[2]) < 0).reshape(blocks, block)
        assert not facing[skipped].any()
        skipped_total += skipped.sum()
        upper = np.where(ad <= dlen * cones[:, 3], ad * cones[:, 3] + cross * cones[:, 4], dlen)
        all_facing = (cones[:, 9] != 0) & (upper + r < 0)
        assert facing[all_facing].all()
        facing_total += all_facing.sum()
    # and the tests are worth having: with blocks of 128 vertices they skip about a fifth of
    # the blocks and pass an eighth without the per-vertex test
    assert skipped_total > 0.15 * blocks * len(bs)
    assert facing_total > 0.1 * blocks * len(bs)


def test_body_arrays_are_uploaded_again_only_for_another_body(monkeypatch):
    from mmocap.testing.evaluators import FRONT, PlateBody, empty_masks

    calls = []
    original = opencl.vertex_arrays
    monkeypatch.setattr(
        opencl, "vertex_arrays", lambda body, scale, block: calls.append(body) or original(body, scale, block)
    )
    blob, plate = BlobBody(), PlateBody()
    ev, uploads = opencl.OpenCLEvaluator(), []
    for body in (blob, blob, plate, blob):
        before = len(calls)
        ev.setup(body, [FRONT], empty_masks([FRONT]))
        uploads.append(len(calls) - before)
        X = test_poses() if body is blob else test_poses()[:, :3]
        got = ev.counts(X)
        fresh = opencl.OpenCLEvaluator()
        fresh.setup(body, [FRONT], empty_masks([FRONT]))
        for a, b in zip(got, fresh.counts(X)):
            np.testing.assert_array_equal(a, b)
    assert uploads == [1, 0, 1, 1]


@pytest.mark.parametrize(
    ("missing", "message"),
    [
        ("double_fp_config", "no double precision"),
        ("endian_little", "big-endian"),
    ],
)
def test_a_device_without_what_the_kernel_needs_is_a_config_error(missing, message):
    real = opencl_devices.select_device(None, 0)

    class Device:  # the real device, less one capability
        def __getattr__(self, name):
            return 0 if name == missing else getattr(real, name)

    with pytest.raises(ConfigError, match=message):
        opencl._DeviceQueue(Device(), opencl_devices.context([real]), None, None)


@pytest.mark.parametrize(
    ("kind", "native", "compiled", "lanes"),
    [
        ("CPU", 16, 512, 16),
        ("CPU", 16, 256, 8),  # PoCL 3.0 on a Zen 4: AVX-512 reported, AVX2 compiled
        ("CPU", 16, 0, 16),  # the compiler does not say: as reported
        ("CPU", 8, 0, 8),
        ("CPU", 4, 128, 8),
        ("GPU", 16, 0, 4),
        ("GPU", 1, 0, 4),
    ],
)
def test_a_cpu_gets_one_vector_register_of_lanes_by_default(monkeypatch, kind, native, compiled, lanes):
    from types import SimpleNamespace

    cl = opencl_devices.pyopencl()
    device = SimpleNamespace(type=getattr(cl.device_type, kind), native_vector_width_float=native)
    with monkeypatch.context() as patched:
        patched.setattr(opencl, "compiled_vector_bits", lambda ctx, dev: compiled)
        assert opencl.default_lanes(device, None) == lanes
    real = opencl_devices.select_device(None, 0)  # and the evaluator takes it
    expected = opencl.default_lanes(real, opencl_devices.context([real]))
    assert opencl.OpenCLEvaluator()._device_queues[0].simd_lanes == expected


def test_the_compiled_vector_width_is_that_of_a_register():
    real = opencl_devices.select_device(None, 0)
    assert opencl_devices.compiled_vector_bits(opencl_devices.context([real]), real) in (0, 128, 256, 512)


@pytest.mark.parametrize("max_layers", [1, 2, 4])
def test_views_with_several_patch_sides_give_naive_counts_whatever_the_layer_limit(monkeypatch, max_layers):
    """Views with more distinct patch sides than layers fall back to stamping patches."""
    from mmocap.evaluators.silhouette import view_geometry
    from mmocap.testing.evaluators import naive_counts

    # the limit the evaluator passes at run time; the kernel stays built for MAX_LAYERS
    monkeypatch.setattr(opencl, "MAX_LAYERS", max_layers)
    distinct = []
    for rig in sorted(RIGS):
        for patch_scale in (1.0, 1.7):
            ev = opencl.OpenCLEvaluator(patch_scale=patch_scale)
            ev.setup(BlobBody(), RIGS[rig], masks(rig, "true"))
            for got, expected in zip(ev.counts(test_poses()), naive_counts(rig, patch_scale, "true")):
                np.testing.assert_array_equal(got, expected)
            _, side = view_geometry(BlobBody(), RIGS[rig], test_poses(), patch_scale)
            distinct += [len(np.unique(s[(s > 0) & (s <= 32)])) for s in side.reshape(-1, side.shape[-1])]
    assert max(distinct) > 2  # views that need several layers occur


def test_blas_runs_on_one_thread_while_a_cpu_device_is_set_up(monkeypatch):
    from threadpoolctl import threadpool_info, threadpool_limits

    from mmocap.evaluators import silhouette
    from mmocap.testing.evaluators import FRONT, empty_masks

    # evaluators of other tests that were never closed do not count here
    monkeypatch.setattr(silhouette, "_BLAS", silhouette._OneBlasThread())

    def blas_threads():
        return {lib["filepath"]: lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}

    np.linalg.eigh(np.eye(3))  # BLAS is loaded
    if not blas_threads():
        pytest.skip("no BLAS library that threadpoolctl can see")
    with threadpool_limits(2, user_api="blas"):
        ev = opencl.OpenCLEvaluator()
        if not ev.owns_cores:
            pytest.skip("the OpenCL device is not a CPU")
        before = blas_threads()
        other = opencl.OpenCLEvaluator()
        for e in (ev, other):
            e.setup(BlobBody(), [FRONT], empty_masks([FRONT]))
            e.setup(BlobBody(), [FRONT], empty_masks([FRONT]))
        ev.close()
        assert set(blas_threads().values()) == {1}  # the other one still needs it
        other.close()
        assert blas_threads() == before


@pytest.mark.parametrize(
    "make",
    [
        lambda: opencl.OpenCLEvaluator(patch_scale=1.5),
        lambda: opencl.OpenCLEvaluator(patch_scale=1.5, local_size=32),
        lambda: opencl.MultiDeviceEvaluator(patch_scale=1.5),
    ],
    ids=["one-work-item", "work-groups-of-32", "multidevice"],
)
def test_a_body_with_a_kinematic_chain_gets_its_transforms_on_the_device_bit_for_bit(make):
    import pyopencl as cl

    from mmocap import registry
    from mmocap.testing.scene import Scene

    scene = Scene(13695, cameras=3)
    rng = np.random.default_rng(7)
    X = scene.body.clip(
        scene.pose + rng.normal(0, 0.3, (9, 51)) * scene.body.mask + np.r_[rng.normal(0, 80, 3), np.zeros(48)]
    )
    ev = make()
    ev.setup(scene.body, scene.cameras, scene.foreground)
    assert ev._chain is scene.body.chain
    with registry.make_evaluator("numpy", patch_scale=1.5) as reference:
        reference.setup(scene.body, scene.cameras, scene.foreground)
        for got, expected in zip(ev.counts(X), reference.counts(X)):
            np.testing.assert_array_equal(got, expected)
    if len(ev._device_queues) == 1:  # the transforms themselves, as the kernel has them in local memory
        device_queue = ev._device_queues[0]
        options = opencl_layout.build_options(device_queue.local_size, device_queue.simd_lanes, device_queue.block)
        probe = cl.Program(device_queue.ctx, opencl_devices.kernel_source() + TRANSFORMS_PROBE).build(options=options)
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        poses = cl.Buffer(device_queue.ctx, flags, hostbuf=ev._chain.pose_rows(X))
        device = np.empty((len(X), 16, 12))
        out = cl.Buffer(device_queue.ctx, cl.mem_flags.WRITE_ONLY, device.nbytes)
        local = cl.LocalMemory(opencl_layout.TRANSFORM_BYTES * 16)
        size = device_queue.local_size
        probe.transforms_probe(
            device_queue.queue, (len(X) * size,), (size,), poses, device_queue.frame["chain"], np.int32(16), local, out
        )
        cl.enqueue_copy(device_queue.queue, device, out, is_blocking=True)
        host = scene.body.transforms(X)[:, :, :3].reshape(len(X), 16, 12)
        np.testing.assert_array_equal(device, host)
    ev.close()


# a kernel that writes out the transforms silhouette_counts computes for each candidate
TRANSFORMS_PROBE = """
__kernel __attribute__((reqd_work_group_size(LOCAL_SIZE, 1, 1)))
void transforms_probe(__global const double *poses, __global const double *chain, const int J,
                      __local double *transforms, __global double *out)
{
    const int i = get_group_id(0), lid = get_local_id(0);
    candidate_transforms(poses + i * (3 + 6 * J), chain, 1, J, lid, transforms);
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int k = lid; k < 12 * J; k += LOCAL_SIZE) out[12 * J * i + k] = transforms[k];
}
"""


class OffBy(opencl.OpenCLEvaluator):
    """A device that counts ``extra`` model pixels too many in every view."""

    extra = 1

    def _counts(self, X):
        model_px, overlap_px = super()._counts(X)
        return model_px + self.extra, overlap_px


class FarOff(OffBy):
    extra = 100


def test_the_self_check_runs_an_exact_device_and_records_it():
    from mmocap import provenance

    ev = opencl.OpenCLEvaluator(lanes=4)
    assert ev.check == "exact"
    assert provenance.facts()["opencl_checks"][ev.where] == "exact"
    assert ev.body is None  # the test scene is gone again


def test_an_inexact_device_runs_only_within_the_tolerance_and_when_asked():
    from mmocap import provenance

    with pytest.raises(
        ConfigError,
        match=r"counts a test scene differently from numpy \(model pixels "
        r".*within the 1 % of accept_inexact: set accept_inexact=true",
    ):
        OffBy()
    ev = OffBy(accept_inexact=True)
    assert ev.check == "within tolerance (largest difference 1 px)"
    assert provenance.facts()["opencl_checks"][ev.where] == ev.check
    with pytest.raises(ConfigError, match=r"beyond the 1 % of accept_inexact: choose another device"):
        FarOff(accept_inexact=True)


def test_a_mask_row_larger_than_local_memory_says_what_to_change(monkeypatch):
    from mmocap.camera import Camera

    ev = opencl.OpenCLEvaluator()
    # 200 bytes beside the body's joint transforms: less than a 1920 px row
    joints = len(BlobBody().joint_rest_positions)
    monkeypatch.setattr(ev._device_queues[0], "local_bytes", 200 + opencl_layout.TRANSFORM_BYTES * joints)
    hd = Camera.look_at("hd", (0, 500, 3000), (0, 400, 0), 1500.0, 1920, 1080)
    with pytest.raises(
        ConfigError,
        match=r"a row of a 1920 px wide mask does not fit the 200 bytes of OpenCL local memory of "
        r".*: use narrower masks, a device with more local memory \(platform, device\) or evaluator=numpy",
    ):
        ev.setup(BlobBody(), [hd], [np.zeros((1080, 1920), bool)])


@pytest.mark.parametrize(
    ("width", "height", "local_bytes", "path"),
    [
        (640, 480, 46112, "whole"),  # 24 words a row, the spare word rounded up to 8
        (640, 480, 46108, "in 2 bands of 479 rows"),
        (1920, 1080, 32768, "in 9 bands of 127 rows"),  # 64 words a row, 8 spare words
        (1920, 1080, 287, "refused"),
    ],
)
def test_the_mask_path_follows_the_local_memory(width, height, local_bytes, path):
    assert opencl.mask_path(width, height, local_bytes) == path


def hd_scene():
    """Cameras of three sizes (200x150; 320x240 with patches of 13 px and more; 1920x1080
    close up) and foregrounds with holes."""
    from mmocap.camera import Camera
    from mmocap.testing.evaluators import NEAR, SMALL

    hd = Camera.look_at("hd", (0, 500, 1500), (0, 400, 0), 1500.0, 1920, 1080)
    cameras = (SMALL, NEAR, hd)
    rng = np.random.default_rng(3)
    with opencl.NumpyEvaluator() as ev:
        ev.setup(BlobBody(), cameras, [np.zeros((cam.height, cam.width), bool) for cam in cameras])
        foreground = [
            ev.render(test_poses()[4], c) & (rng.random((cam.height, cam.width)) < 0.8) for c, cam in enumerate(cameras)
        ]
    return cameras, foreground


@pytest.mark.parametrize("local_size", [1, 32])
@pytest.mark.parametrize("max_local_bytes", [300, 4000, 40000])
def test_masks_in_bands_count_render_and_project_as_the_whole_mask_bit_for_bit(local_size, max_local_bytes):
    from mmocap.testing.evaluators import blob_keypoints

    cameras, foreground = hd_scene()
    setup = (BlobBody(), cameras, foreground, blob_keypoints("front-side-near"))  # 3 cameras' keypoints
    X = np.concatenate([test_poses(), test_poses()[:4] + np.r_[0, 0, 300.0, np.zeros(5)]])
    with opencl.NumpyEvaluator() as reference:
        reference.setup(*setup)
        expected = reference.counts_and_pixels(X)
    with opencl.OpenCLEvaluator(local_size=local_size) as whole:
        whole.setup(*setup)
        assert whole.bands == (1, 1080)
        unbanded = whole.counts_and_pixels(X)
        rendered = [whole.render(X[4], c) for c in range(len(cameras))]
    with opencl.OpenCLEvaluator(local_size=local_size, max_local_bytes=max_local_bytes) as banded:
        banded.setup(*setup)
        bands, rows = banded.bands
        got = banded.counts_and_pixels(X)
        for c, mask in enumerate(rendered):
            np.testing.assert_array_equal(banded.render(X[4], c), mask)
    assert bands == -(-1080 // rows) > 1
    for mask in rendered if rows < 100 else rendered[2:]:  # the body crosses band boundaries
        spanned = np.flatnonzero(mask.any(axis=1))
        assert spanned[0] // rows < spanned[-1] // rows
    for counts, whole_counts, numpy_counts in zip(got[:2], unbanded[:2], expected[:2]):
        np.testing.assert_array_equal(counts, whole_counts)
        np.testing.assert_array_equal(counts, numpy_counts)
    assert expected[1].max() > 0
    # the model points' pixels: float32 bits, NaN behind a camera
    np.testing.assert_array_equal(got[2].view(np.uint32), expected[2].view(np.uint32))
    np.testing.assert_array_equal(got[2].view(np.uint32), unbanded[2].view(np.uint32))


def test_a_work_group_larger_than_the_kernel_allows_is_a_config_error(monkeypatch):
    cl = opencl_devices.pyopencl()
    real, built = opencl_devices.select_device(None, 0), cl.Kernel

    class Kernel(built):  # the built kernel, with a work-group limit of 16
        def get_work_group_info(self, what, device):
            limit = what == cl.kernel_work_group_info.WORK_GROUP_SIZE
            return 16 if limit else super().get_work_group_info(what, device)

    monkeypatch.setattr(cl, "Kernel", Kernel)
    with pytest.raises(ConfigError, match="local_size=32 is more than the kernel can run on .*at most 16"):
        opencl._DeviceQueue(real, opencl_devices.context([real]), 32, None)


def test_mmocap_list_shows_each_devices_self_check():
    done = run_python("from mmocap.cli import main\nmain(['list'])")
    assert done.returncode == 0, done.stderr
    assert "OpenCL devices, self-checked against numpy" in done.stdout
    assert ": self-check exact" in done.stdout
    # each device's rendering path for a full-HD mask
    assert re.search(
        r"self-check exact; \d+ bytes of local memory for masks: 1920x1080 (whole|in \d+ bands)", done.stdout
    )


@pytest.mark.parametrize(
    "make",
    [
        lambda: opencl.OpenCLEvaluator(),
        lambda: opencl.OpenCLEvaluator(local_size=32),
        lambda: opencl.MultiDeviceEvaluator(sub_devices=2),
    ],
    ids=["one-work-item", "work-groups-of-32", "multidevice"],
)
def test_the_model_points_of_a_body_with_a_kinematic_chain_project_as_numpy_bit_for_bit(make):
    from mmocap import registry
    from mmocap.bench.keypoints import scene_keypoints
    from mmocap.testing.scene import Scene

    scene = Scene(13695, cameras=3)
    keypoints = scene_keypoints(scene)
    X = scene.candidates(9)
    ev = make()
    ev.setup(scene.body, scene.cameras, scene.foreground, keypoints)
    assert ev._chain is scene.body.chain  # the kernel computes the transforms
    with registry.make_evaluator("numpy") as reference:
        reference.setup(scene.body, scene.cameras, scene.foreground, keypoints)
        expected = reference.counts_and_pixels(X)
        model_px, overlap_px, pixels = ev.counts_and_pixels(X)
        np.testing.assert_array_equal(model_px, expected[0])
        np.testing.assert_array_equal(overlap_px, expected[1])
        np.testing.assert_array_equal(pixels.view(np.uint32), expected[2].view(np.uint32))
        np.testing.assert_array_equal(ev(X), reference(X))
    assert expected[2].shape == (9, 3, 17, 2)
    assert np.isfinite(expected[2]).all()
    ev.close()


@pytest.mark.parametrize("local_size", [1, 32])
def test_buffers_kept_across_calls_of_other_population_sizes_give_fresh_results(local_size):
    from mmocap import registry
    from mmocap.bench.keypoints import scene_keypoints
    from mmocap.testing.scene import Scene

    scene = Scene(13695, cameras=3)
    keypoints = scene_keypoints(scene)
    ev = opencl.OpenCLEvaluator(local_size=local_size)
    ev.setup(scene.body, scene.cameras, scene.foreground, keypoints)
    assert ev._chain is scene.body.chain  # with the chain's buffers kept too
    with registry.make_evaluator("numpy") as reference:
        reference.setup(scene.body, scene.cameras, scene.foreground, keypoints)
        # the kept buffers grow with n (3, then 14) and keep their arguments: each call must
        # still see only its own poses, counts and pixels, with or without pixels asked for
        for seed, n, pixels in ((1, 3, False), (2, 14, False), (3, 3, True), (4, 14, True), (5, 3, False)):
            X = scene.candidates(n, seed=seed)
            expected = reference.counts_and_pixels(X)
            got = ev.counts_and_pixels(X) if pixels else (*ev.counts(X), expected[2])
            np.testing.assert_array_equal(got[0], expected[0])
            np.testing.assert_array_equal(got[1], expected[1])
            np.testing.assert_array_equal(got[2].view(np.uint32), expected[2].view(np.uint32))
        np.testing.assert_array_equal(ev.render(X[-1], 1), reference.render(X[-1], 1))
        np.testing.assert_array_equal(ev.counts(X)[0], reference.counts(X)[0])  # after the masks' launch
    ev.close()


def test_the_model_points_go_up_when_they_change_and_their_pixels_come_with_the_counts(monkeypatch):
    import pyopencl as cl

    from mmocap.evaluators.keypoint_term import Keypoints
    from mmocap.testing.evaluators import blob_keypoints

    rig = "front-side-near"
    body, cameras, foreground = BlobBody(), RIGS[rig], masks(rig, "true")
    ev = opencl.OpenCLEvaluator()
    device_queue = ev._device_queues[0]
    uploads, upload = [], device_queue.upload
    monkeypatch.setattr(device_queue, "upload", lambda **arrays: uploads.extend(arrays) or upload(**arrays))
    kp = blob_keypoints(rig)
    moved = Keypoints(kp.points, kp.offsets_mm + 10.0, kp.observed, kp.term)
    points_uploaded = []
    for keypoints in (kp, kp, None, kp, moved):
        uploads.clear()
        ev.setup(body, cameras, foreground, keypoints)
        points_uploaded.append(sorted(k for k in uploads if k.startswith("point")))
    assert points_uploaded == [["point_joint", "point_rest"], [], [], [], ["point_joint", "point_rest"]]
    ev.close()
    uploads.clear()
    ev.setup(body, cameras, foreground, kp)
    assert "point_joint" in uploads
    # one launch either way; the pixels are written (K > 0) and read back only when asked for
    calls = {"enqueue_copy": 0, "enqueue_nd_range_kernel": 0}
    for name in calls:
        monkeypatch.setattr(cl, name, functools.partial(counted, getattr(cl, name), calls, name))
    X = test_poses()
    ev.counts(X)
    assert calls == {"enqueue_copy": 1, "enqueue_nd_range_kernel": 1}
    assert device_queue.bound[device_queue.kernel.int_ptr][-1] == 0  # K, the last of the arguments' key
    ev.counts_and_pixels(X)  # the pixels come back with the counts, in the same copy
    assert calls == {"enqueue_copy": 2, "enqueue_nd_range_kernel": 2}
    assert device_queue.bound[device_queue.kernel.int_ptr][-1] == len(kp.points)
    ev.close()


@pytest.mark.parametrize("local_size", [1, 32])
def test_a_body_with_a_kinematic_chain_is_one_launch_and_one_read_back_per_call(monkeypatch, local_size):
    import pyopencl as cl

    from mmocap.bench.keypoints import scene_keypoints
    from mmocap.testing.scene import Scene

    scene = Scene(3000, cameras=3)
    ev = opencl.OpenCLEvaluator(local_size=local_size)
    ev.setup(scene.body, scene.cameras, scene.foreground, scene_keypoints(scene))
    assert ev._chain is scene.body.chain
    calls = {"enqueue_copy": 0, "enqueue_nd_range_kernel": 0}
    for name in calls:
        monkeypatch.setattr(cl, name, functools.partial(counted, getattr(cl, name), calls, name))
    ev.counts(scene.candidates(5))
    ev.counts_and_pixels(scene.candidates(5))
    assert calls == {"enqueue_copy": 2, "enqueue_nd_range_kernel": 2}
    ev.close()


def counted(function, calls, name, *args, **kwargs):
    """``function`` that counts its calls in ``calls[name]``."""
    calls[name] += 1
    return function(*args, **kwargs)


def test_platform_null_takes_a_gpu_whatever_order_the_loader_lists_the_platforms_in(monkeypatch):
    from types import SimpleNamespace

    cl = opencl_devices.pyopencl()

    def platform(name, *types):
        devices = [SimpleNamespace(type=t, name=f"{name} device") for t in types]
        return SimpleNamespace(name=name, get_devices=lambda: devices)

    simulator, pocl = (
        platform("Oclgrind", cl.device_type.GPU),
        platform("Portable Computing Language", cl.device_type.CPU),
    )
    nvidia = platform("NVIDIA CUDA", cl.device_type.GPU)
    for listed, chosen in (([simulator, pocl, nvidia], nvidia), ([nvidia, pocl], nvidia), ([simulator, pocl], pocl)):
        monkeypatch.setattr(opencl_devices, "platforms", lambda listed=listed: listed)
        assert opencl_devices.select_platform(None) is chosen


@pytest.mark.parametrize("views", [1, 2, 3])
@pytest.mark.parametrize("max_local_bytes", [None, 4000])
def test_every_number_of_cameras_per_work_group_counts_and_projects_as_numpy(monkeypatch, views, max_local_bytes):
    from mmocap import registry
    from mmocap.bench.keypoints import scene_keypoints
    from mmocap.testing.scene import Scene

    scene = Scene(3000, cameras=3)
    keypoints = scene_keypoints(scene)
    X = scene.candidates(5)
    # 2 cameras per group: the second group of each candidate holds only the third camera
    monkeypatch.setattr(opencl, "views_per_group", lambda local_size, cameras, candidates, units: views)
    with (
        opencl.OpenCLEvaluator(max_local_bytes=max_local_bytes) as ev,
        registry.make_evaluator("numpy") as reference,
    ):
        ev.setup(scene.body, scene.cameras, scene.foreground, keypoints)
        reference.setup(scene.body, scene.cameras, scene.foreground, keypoints)
        assert (ev.bands[0] > 1) == (max_local_bytes is not None)
        got, expected = ev.counts_and_pixels(X), reference.counts_and_pixels(X)
        np.testing.assert_array_equal(got[0], expected[0])
        np.testing.assert_array_equal(got[1], expected[1])
        np.testing.assert_array_equal(got[2].view(np.uint32), expected[2].view(np.uint32))
        np.testing.assert_array_equal(ev.render(X[3], 2), reference.render(X[3], 2))
