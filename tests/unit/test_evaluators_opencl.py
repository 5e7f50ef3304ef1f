"""OpenCL evaluators: device selection, clear errors, the program cache, the multi-device split."""
import os
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("pyopencl")
from mmocap.errors import ConfigError  # noqa: E402
from mmocap.evaluators import opencl  # noqa: E402
from mmocap.testing.evaluators import RIGS, BlobBody, masks, test_poses  # noqa: E402

try:
    opencl.platforms()
except ConfigError:
    pytest.skip("no OpenCL platform on this machine", allow_module_level=True)


def run_python(code: str, **env) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, **env}, timeout=120)


def test_no_platform_is_a_config_error_that_says_what_to_install():
    # an ICD vendor folder with no driver in it hides every platform, PoCL included
    done = run_python("from mmocap import registry\n"
                      "registry.make_evaluator('opencl')", OCL_ICD_VENDORS="/nonexistent")
    assert done.returncode != 0
    assert "ConfigError: no OpenCL platform found" in done.stderr
    assert "pocl-binary-distribution" in done.stderr


@pytest.mark.parametrize("kwargs, message", [
    ({"device": 99}, r"device index 99 does not exist on platform .*\[0\]"),
    ({"device": "first"}, r"device must be an index, got 'first'"),
    ({"platform": 42}, r"platform index 42 does not exist; there are \d+: \[0\]"),
    ({"platform": "no-such-vendor"}, r"no OpenCL platform matches platform='no-such-vendor'"),
    ({"local_size": 0}, r"local_size must be in \[1, \d+\]"),
])
def test_bad_device_selection_names_the_value(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        opencl.OpenCLEvaluator(**kwargs)


def test_too_many_sub_devices_is_a_config_error():
    units = opencl.select_device(None, 0).max_compute_units
    with pytest.raises(ConfigError, match=f"into {units + 1} sub-devices"):
        opencl.MultiDeviceEvaluator(sub_devices=units + 1)


def test_platform_by_name_and_program_built_once_per_process():
    name = opencl.platforms()[0].name.split()[0].lower()
    a, b = opencl.OpenCLEvaluator(platform=name), opencl.OpenCLEvaluator(platform=0)
    assert a.devices == b.devices
    assert a._lanes[0].kernel.program.int_ptr == b._lanes[0].kernel.program.int_ptr


def test_each_process_gets_its_own_pocl_cache_dir():
    parent = os.environ["POCL_CACHE_DIR"]
    assert os.path.isdir(parent)
    done = run_python("import os\nfrom mmocap.evaluators import opencl\n"
                      "print(os.environ['POCL_CACHE_DIR'])")
    child = done.stdout.strip()
    assert done.returncode == 0 and child and child != parent
    assert not os.path.exists(child)  # removed when the child exits


@pytest.mark.parametrize("local_size", [1, 3, 32])
def test_multidevice_split_and_work_group_sizes_give_one_devices_counts(local_size):
    rig = "front-side-near"
    single = opencl.OpenCLEvaluator(local_size=1)
    multi = opencl.MultiDeviceEvaluator(local_size=local_size)
    assert len(multi.devices) >= 2 or opencl.select_device(None, 0).max_compute_units == 1
    for ev in (single, multi):
        ev.setup(BlobBody(), RIGS[rig], masks(rig, "true"))
    X = test_poses()
    for n in (1, 2, 3, len(X)):
        for got, expected in zip(multi.counts(X[:n]), single.counts(X[:n])):
            np.testing.assert_array_equal(got, expected)
