"""mmocap and its example plugins as a user installs them: built wheels in a fresh virtual
environment, run from an empty folder outside the repository (``make test-wheel``).

The environment is built once for the module: the mmocap wheel with its dependencies, a
wheel of every plugin folder under ``plugins/`` and pytest. Nothing of the source tree is
importable there: the checks fail if a config, kernel or asset is missing from a wheel.
"""

import json
import os
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pandas as pd
import pytest

from mmocap.stages import segmentation

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
PLUGINS = sorted(p for p in (REPO / "plugins").iterdir() if (p / "pyproject.toml").is_file())
SUBCOMMANDS = (
    "track",
    "generate",
    "list",
    "export-humaneva",
    "check-recording",
    "to-recording",
    "export",
    "collect",
    "ioh",
    "summaries",
    "stats",
    "paper",
    "bench",
    "foreground-quality",
)
SMALL = [
    "dataset.frames=2",
    "dataset.width=320",
    "dataset.height=240",
    "dataset.background_frames=3",
    "dataset.cameras=[C1,C2,BW1]",
    "dataset.all_cameras=[C1,C2,BW1]",
    "dataset.root=data",
    "body.vertices=2000",
    "tracking.frames=2",
    "tracking.evaluations=150",
    "overlays=0",
    "progress=false",
]


def run(command: list, cwd: Path, timeout: float = 600, env: dict | None = None) -> subprocess.CompletedProcess:
    """``command`` in ``cwd``; fails the test with its output when it exits non-zero."""
    start = time.perf_counter()
    done = subprocess.run([str(c) for c in command], cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env)
    print(f"{time.perf_counter() - start:6.1f} s  {' '.join(map(str, command))[:150]}")
    assert done.returncode == 0, f"{command} exited {done.returncode}:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done


def distribution_name(plugin: Path) -> str:
    return tomllib.loads((plugin / "pyproject.toml").read_text())["project"]["name"]


def entry_points(plugin: Path) -> dict[str, list[str]]:
    """The plugin's registered names by kind (``optimizer``, ``evaluator``, ``detector``)."""
    project = tomllib.loads((plugin / "pyproject.toml").read_text())["project"]
    groups = project.get("entry-points", {})
    return {kind: sorted(groups.get(f"mmocap.{kind}s", {})) for kind in ("optimizer", "evaluator", "detector")}


def choosing(kind: str, name: str) -> list[str]:
    """The overrides that make a run use the component ``name`` of ``kind``."""
    if kind == "detector":
        return ["keypoints.source=detector", f"keypoints.detector={name}"]
    return [f"{kind}={name}"]


@pytest.fixture(scope="module")
def venv(tmp_path_factory) -> dict:
    """A fresh venv with the wheels installed; returns its bin folder, an environment
    without the repository on any path, and an empty working folder."""
    root = tmp_path_factory.mktemp("wheel")
    wheels = root / "wheels"
    for source in [REPO, *PLUGINS]:
        run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", wheels, source], cwd=root)
    # A build leaves build/ and *.egg-info beside the sources; keep the tree clean.
    for source in [REPO, *PLUGINS]:
        shutil.rmtree(source / "build", ignore_errors=True)
    run([sys.executable, "-m", "venv", root / "venv"], cwd=root)
    bin_dir = root / "venv" / "bin"
    mmocap_wheel = next(wheels.glob("mmocap-*.whl"))
    plugin_wheels = [w for w in wheels.glob("*.whl") if w != mmocap_wheel]
    run(
        [bin_dir / "python", "-m", "pip", "install", "-q", f"{mmocap_wheel}[segment]", *plugin_wheels, "pytest"],
        cwd=root,
        timeout=900,
    )
    # MediaPipe as the install line says (without its declared dependencies), for the detectors
    mediapipe = segmentation.INSTALL.split("--no-deps ")[1]
    run([bin_dir / "python", "-m", "pip", "install", "-q", "--no-deps", mediapipe], cwd=root, timeout=900)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{bin_dir}{os.pathsep}{env['PATH']}"
    work = root / "work"
    work.mkdir()
    return {"bin": bin_dir, "env": env, "work": work, "wheels": wheels}


def mmocap(venv, *args, cwd=None, timeout=600):
    return run([venv["bin"] / "mmocap", *args], cwd=cwd or venv["work"], env=venv["env"], timeout=timeout)


def test_the_wheel_carries_configs_kernels_and_mesh(venv):
    import zipfile

    names = zipfile.ZipFile(next(venv["wheels"].glob("mmocap-*.whl"))).namelist()
    assert "mmocap/conf/config.yaml" in names
    assert "mmocap/conf/experiment/table4.yaml" in names
    assert "mmocap/evaluators/kernels/silhouette.cl" in names
    assert any(n.startswith("mmocap/body/assets/makehuman/") for n in names)


def test_mmocap_is_imported_from_the_venv_not_the_checkout(venv):
    done = run(
        [venv["bin"] / "python", "-c", "import mmocap, mmocap.conf; print(mmocap.__file__)"],
        cwd=venv["work"],
        env=venv["env"],
    )
    assert "site-packages" in done.stdout
    assert str(REPO) not in done.stdout


def test_help_lists_every_subcommand_in_one_line_each(venv):
    out = mmocap(venv, "--help").stdout
    for name in SUBCOMMANDS:
        lines = [line for line in out.splitlines() if line.strip().startswith(name + " ")]
        assert len(lines) == 1, f"{name} in:\n{out}"


def test_list_names_builtins_and_plugins_with_their_distribution(venv):
    out = mmocap(venv, "list").stdout
    for name in ("cmaes", "pso", "numpy", "opencl", "auto"):
        assert f"  {name} " in out, out
    for plugin in PLUGINS:
        for names in entry_points(plugin).values():
            for name in names:
                line = next(line for line in out.splitlines() if line.strip().startswith(name + " "))
                assert f"[{distribution_name(plugin)}]" in line, line


def test_generates_and_tracks_with_numpy_and_opencl_alike(venv):
    mmocap(venv, "generate", *SMALL)
    errors = {}
    for evaluator in ("numpy", "opencl"):
        mmocap(venv, *SMALL, f"evaluator={evaluator}", f"hydra.run.dir=runs/{evaluator}")
        summary = json.loads((venv["work"] / "runs" / evaluator / "summary.json").read_text())
        assert summary["backend"] == evaluator
        assert summary["frames"] == 2
        errors[evaluator] = summary["mean_marker_error_mm"]
    assert errors["numpy"] == errors["opencl"]  # the same pixel counts, so the same search


def test_a_recording_is_tracked_from_nothing_and_exported_without_extras(venv):
    """The path of a user's own recording from the installed wheel alone: without the video
    extra the videos are OpenCV's MPEG-4 (lossy), without the export extra no C3D."""
    mmocap(venv, "generate", *SMALL)
    mmocap(venv, "to-recording", "data/S1_walking", "rec", "--crf", "16", "--no-progress")
    assert "frames tracked: 2" in mmocap(venv, "check-recording", "rec").stdout
    quick_start = [
        "start.headings=4",
        "start.candidates=1",
        "start.refined=1",
        "start.evaluations=60",
        "start.limb_evaluations=30",
        "start.limb_samples=20",
        "start.limb_restarts=1",
        "start.rounds=1",
        "start.girth_steps=[]",
        "start.height_steps_mm=[]",
        "start.hull_height_offsets_mm=[0]",
    ]
    mmocap(
        venv,
        "dataset=recording",
        "dataset.root=rec",
        "body.vertices=2000",
        "tracking.evaluations=150",
        "overlays=0",
        "progress=false",
        "hydra.run.dir=runs/rec",
        "export=[bvh,trc,csv]",
        *quick_start,
    )
    summary = json.loads((venv["work"] / "runs" / "rec" / "summary.json").read_text())
    assert summary["start"]["method"] == "search"
    assert summary["frames"] == 2
    assert sorted(p.name for p in (venv["work"] / "runs" / "rec" / "export").iterdir()) == [
        "joints_mm.csv",
        "markers_mm.csv",
        "motion.bvh",
        "motion.trc",
        "pose.csv",
    ]


def test_a_two_job_sweep_makes_a_paper_figure(venv):
    mmocap(
        venv,
        "-m",
        "+experiment=fig10",
        "scale=smoke",
        "settings=paper",
        "algorithm=cmaes-holistic,pso-holistic",
        "dataset.root=data-smoke",
        "hydra.sweep.dir=sweep",
    )
    runs = pd.read_csv(venv["work"] / "sweep" / "runs.csv")
    assert sorted(runs.algorithm) == ["cmaes-holistic", "pso-holistic"]
    out = mmocap(venv, "paper", "fig10", "sweep", "--out", "paper").stdout
    assert (venv["work"] / "paper" / "figures" / "fig10_realistic_paper.png").read_bytes()[:4] == b"\x89PNG", out


@pytest.mark.parametrize("plugin", PLUGINS, ids=[p.name for p in PLUGINS])
def test_plugin_passes_its_own_tests_outside_the_checkout(venv, plugin, tmp_path):
    tests = tmp_path / plugin.name
    shutil.copytree(plugin / "tests", tests)
    run(
        [venv["bin"] / "python", "-m", "pytest", "-q", "-p", "no:cacheprovider", tests],
        cwd=tmp_path,
        env=venv["env"],
        timeout=900,
    )


@pytest.mark.parametrize("plugin", PLUGINS, ids=[p.name for p in PLUGINS])
def test_plugin_runs_in_a_sweep_and_its_version_is_recorded(venv, plugin):
    kind, name = next((k, names[0]) for k, names in entry_points(plugin).items() if names)
    folder = f"sweep-{plugin.name}"
    mmocap(
        venv, "-m", *SMALL, *choosing(kind, name), "seed=0,1", f"hydra.sweep.dir={folder}", "hydra.launcher.n_jobs=1"
    )
    records = sorted((venv["work"] / folder / "records").glob("*.json"))
    assert len(records) == 2
    component = json.loads(records[0].read_text())["provenance"]["components"][kind]
    assert component["distribution"] == distribution_name(plugin)
    assert component["version"] == tomllib.loads((plugin / "pyproject.toml").read_text())["project"]["version"]
