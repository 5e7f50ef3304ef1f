"""The OpenCL kernel's constants have one owner, opencl_layout, and reach the kernel only
through -D build options; the kernel is read as package data."""

import re
from importlib import resources

import numpy as np
import pytest

from mmocap.evaluators import opencl_devices, opencl_layout
from mmocap.evaluators.opencl import OpenCLEvaluator

needs_opencl = pytest.mark.skipif(OpenCLEvaluator.unavailable() is not None, reason="no usable OpenCL device here")


def required_constants(source: str) -> set[str]:
    """The constants the kernel's #error guards ask for."""
    return set(re.findall(r"!defined\((\w+)\)", source))


def test_build_options_pass_exactly_the_constants_the_kernel_requires():
    source = opencl_devices.kernel_source()
    for local_size, lanes, block in ((1, 8, 128), (64, 4, 32)):
        options = opencl_layout.build_options(local_size, lanes, block)
        passed = dict(o[2:].split("=", 1) for o in options if o.startswith("-D"))
        assert set(passed) == required_constants(source)
        assert passed["COUNT_WORDS"] == str(opencl_layout.count_words(local_size))
        assert (passed["LOCAL_SIZE"], passed["LANES"], passed["BLOCK"]) == (str(local_size), str(lanes), str(block))
    for name in required_constants(source):  # the kernel defines none of them itself
        assert not re.search(rf"^\s*#define\s+{name}\b", source, re.MULTILINE), name
    assert {"PAD", "MAX_LAYERS", "PITCH_WORDS", "BLOCK"} <= required_constants(source)


def test_the_kernel_is_package_data():
    packaged = resources.files("mmocap.evaluators") / "kernels" / "silhouette.cl"
    assert opencl_devices.kernel_source() == packaged.read_text()


@needs_opencl
@pytest.mark.parametrize("left_out", ["PAD", "MAX_LAYERS", "PITCH_WORDS", "BLOCK", "NEAR_MM"])
def test_a_missing_constant_fails_the_build(left_out):
    cl = opencl_devices.pyopencl()
    ctx = opencl_devices.context([opencl_devices.select_device(None, 0)])
    options = [o for o in opencl_layout.build_options(1, 8, 128) if not o.startswith(f"-D{left_out}=")]
    with pytest.raises(cl.RuntimeError, match=f"build with .*-D{left_out}"):
        cl.Program(ctx, opencl_devices.kernel_source()).build(options=options)


def test_rows_are_pitch_words_apart():
    assert opencl_layout.pitch(1) == opencl_layout.PITCH_WORDS
    assert opencl_layout.pitch(640) == 24  # 20 words rounded up to 8
    mask = np.random.default_rng(0).random((5, 70)) < 0.5
    packed = opencl_layout.pack_bits(mask, 5 * 8 + 3)
    rows = packed[:40].reshape(5, 8)
    bits = np.unpackbits(rows.view(np.uint8), axis=1, bitorder="little")
    np.testing.assert_array_equal(bits[:, :70], mask)
    assert not bits[:, 70:].any()
    assert not packed[40:].any()


@pytest.mark.parametrize(
    ("vertices", "block"), [(1, 32), (300, 32), (3000, 32), (6000, 64), (13695, 128), (27393, 128), (10**6, 128)]
)
def test_culling_blocks_are_about_a_hundredth_of_the_body_within_limits(vertices, block):
    assert opencl_layout.block_size(vertices) == block
    # every size in between is a power of two, so a multiple of every lane count (4, 8, 16)
    assert opencl_layout.SMALLEST_BLOCK % 16 == 0
    assert opencl_layout.LARGEST_BLOCK % 16 == 0


def test_point_arrays_are_the_kernels_int32_joints_and_float32_rest_positions_rounded_once():
    joint, rest = opencl_layout.point_arrays(np.array([0, 9, 2]), np.array([[0.1, 2.0, -3.0]] * 3))
    assert joint.dtype == np.int32
    assert joint.tolist() == [0, 9, 2]
    assert rest.dtype == np.float32
    assert rest.flags.c_contiguous
    np.testing.assert_array_equal(rest, np.float32([[0.1, 2.0, -3.0]] * 3))


def test_a_cpu_work_group_takes_all_cameras_unless_the_cores_would_wait():
    views = opencl_layout.views_per_group
    assert views(1, 7, 14, 2) == 7  # a CMA-ES generation on 2 cores: the kinematics once per candidate
    assert views(1, 7, 28, 2) == 7
    assert views(1, 7, 1, 2) == 4  # one candidate: 4 and 3 cameras, a core each
    assert views(1, 7, 7, 2) == 1  # 7 groups of 7 on 2 cores would leave one waiting a round
    assert views(1, 1, 256, 2) == 1
    for candidates in range(1, 40):
        for cores in (1, 2, 3, 16):
            v = views(1, 7, candidates, cores)
            assert 1 <= v <= 7
            if candidates % cores == 0:
                assert v == 7  # every core gets whole candidates
    assert views(64, 7, 14, 2) == 1  # work-groups of many work-items (GPUs): one camera each
