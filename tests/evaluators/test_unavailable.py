"""mmocap without pyopencl, or without any OpenCL platform: it imports, ``mmocap list``
says why the OpenCL evaluators are unavailable and what to install, asking for one is a
one-line error, and the default (evaluator=auto) runs on numpy."""

import json
import os
import subprocess
import sys
from types import SimpleNamespace

import pytest

from mmocap import registry
from mmocap.errors import ConfigError
from tests.helpers import overrides

MISSING = {
    # a pyopencl package that cannot be imported, first on the path
    "no-pyopencl": ("pyopencl cannot be imported", "install with: pip install pyopencl pocl-binary-distribution"),
    # an ICD vendor folder with no driver in it hides every platform, PoCL's included
    "no-platform": ("no OpenCL platform found", "install with: pip install pocl-binary-distribution"),
}


def environment(missing: str, tmp_path) -> dict:
    env = dict(os.environ)
    if missing == "no-pyopencl":
        shadow = tmp_path / "shadow" / "pyopencl"
        shadow.mkdir(parents=True)
        (shadow / "__init__.py").write_text("raise ModuleNotFoundError(\"No module named 'pyopencl'\")\n")
        env["PYTHONPATH"] = os.pathsep.join([str(shadow.parent), env.get("PYTHONPATH", "")])
    else:
        pytest.importorskip("pyopencl")  # else there is no platform to hide
        env["OCL_ICD_VENDORS"] = str(tmp_path / "no-vendors")
    return env


def run(args: list[str], env: dict, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], env=env, cwd=cwd, capture_output=True, text=True, timeout=600)


def test_importing_mmocap_and_the_opencl_evaluators_does_not_import_pyopencl(tmp_path):
    code = (
        "import sys\nimport mmocap.cli, mmocap.registry, mmocap.evaluators.opencl, "
        "mmocap.evaluators.auto\nprint('pyopencl' in sys.modules)"
    )
    done = run(["-c", code], dict(os.environ), tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"


@pytest.mark.parametrize("missing", sorted(MISSING))
def test_list_says_why_opencl_is_unavailable_and_what_to_install(tmp_path, missing):
    done = run(["-m", "mmocap", "list"], environment(missing, tmp_path), tmp_path)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    why, install = MISSING[missing]
    for name in ("opencl", "multidevice"):
        [at] = [i for i, line in enumerate(lines) if line.split()[:1] == [name]]
        reason = lines[at + 1].strip()
        assert reason.startswith(f"unavailable: {why}")
        assert install in reason
    for name in ("auto", "numpy", "naive", "cmaes"):
        [at] = [i for i, line in enumerate(lines) if line.split()[:1] == [name]]
        assert at + 1 == len(lines) or "unavailable" not in lines[at + 1]


@pytest.mark.parametrize("missing", sorted(MISSING))
def test_asking_for_opencl_is_a_one_line_error(tiny_sequence, tmp_path, missing):
    root = tmp_path / "data"
    root.mkdir()
    (root / "S1_walking").symlink_to(tiny_sequence)
    done = run(
        ["-m", "mmocap", "evaluator=opencl", *overrides(root), f"hydra.run.dir={tmp_path / 'run'}"],
        environment(missing, tmp_path),
        tmp_path,
    )
    why, install = MISSING[missing]
    assert done.returncode == 2
    [line] = done.stderr.strip().splitlines()
    assert line.startswith(f"mmocap: error: evaluator 'opencl' is unavailable: {why}")
    assert install in line


def test_the_default_runs_on_numpy_without_pyopencl(tiny_sequence, tmp_path):
    root = tmp_path / "data"
    root.mkdir()
    (root / "S1_walking").symlink_to(tiny_sequence)
    run_dir = tmp_path / "run"
    done = run(
        ["-m", "mmocap", *overrides(root, **{"tracking.frames": 1}), "overlays=0", f"hydra.run.dir={run_dir}"],
        environment("no-pyopencl", tmp_path),
        tmp_path,
    )
    assert done.returncode == 0, done.stderr
    assert "evaluator=auto chose numpy: OpenCL is unavailable: pyopencl cannot be imported" in (
        done.stdout + done.stderr
    )
    summary = json.loads((run_dir / "summary.json").read_text())
    assert (summary["evaluator_choice"], summary["backend"]) == ("auto", "numpy")


class Plugin:
    """A registered evaluator class that needs what is not installed."""

    @classmethod
    def unavailable(cls):
        return "needs libwarp; install with: pip install warp-drive"


class PlainPlugin:
    """One without unavailable(): taken to be available."""

    def __init__(self, patch_scale=1.0):
        self.patch_scale = patch_scale


def fake_entry_points(monkeypatch):
    def entry(name, cls):
        return SimpleNamespace(
            name=name, value=f"plugins:{cls.__name__}", dist=SimpleNamespace(name="plugins"), load=lambda: cls
        )

    real = registry.available
    monkeypatch.setattr(
        registry,
        "available",
        lambda kind: {
            **real(kind),
            **({"warp": entry("warp", Plugin), "plain": entry("plain", PlainPlugin)} if kind == "evaluator" else {}),
        },
    )


def test_a_plugin_says_why_it_is_unavailable(monkeypatch):
    fake_entry_points(monkeypatch)
    assert registry.unavailable("evaluator", "warp") == Plugin.unavailable()
    assert registry.unavailable("evaluator", "plain") is None
    lines = registry.describe().splitlines()
    at = [line.split()[:1] for line in lines].index(["warp"])
    assert lines[at + 1].split() == ["unavailable:", *Plugin.unavailable().split()]
    assert "unavailable" not in lines[[line.split()[:1] for line in lines].index(["plain"]) + 1]
    with pytest.raises(ConfigError, match=r"^evaluator 'warp' is unavailable: needs libwarp; install with"):
        registry.make_evaluator("warp")
    assert registry.make_evaluator("plain", patch_scale=2.0).patch_scale == 2.0


def test_bench_backends_are_the_registered_ones_that_can_run(monkeypatch):
    from mmocap.bench.backends import backends

    fake_entry_points(monkeypatch)
    names = backends()
    assert names[0] == "naive"
    assert {"numpy", "plain"} <= set(names)
    assert "auto" not in names
    assert "warp" not in names
    for name in names:
        assert registry.unavailable("evaluator", name) is None
