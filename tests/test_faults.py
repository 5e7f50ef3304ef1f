"""A sweep interrupted by SIGTERM, SIGINT or SIGKILL: no process of it is left running,
nothing is half-written, and the same command then runs exactly the missing jobs."""

import json
import signal
import subprocess
import time
from pathlib import Path

import pandas as pd
import pytest

from mmocap.data.synthetic import generate
from tests.helpers import TINY_BAD_INPUT as TINY
from tests.helpers import fault_sweep_command, processes_left

JOBS = 6


@pytest.fixture(scope="module")
def sequence(tmp_path_factory) -> Path:
    return generate(tmp_path_factory.mktemp("faults") / "S1_walking", progress=False, **TINY)


def sweep_command(sequence: Path, folder: Path) -> list[str]:
    return fault_sweep_command(sequence, folder, JOBS, "hydra.launcher.n_jobs=2")


def records(folder: Path) -> dict[str, float]:
    """run_id -> modification time of every record; each must be a whole record."""
    found = {}
    for path in sorted((folder / "records").glob("*.json")):
        record = json.loads(path.read_text())
        assert record["summary"]["frames"] == TINY["frames"]
        found[path.stem] = path.stat().st_mtime_ns
    return found


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc to find the processes")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGKILL], ids=lambda s: s.name)
def test_an_interrupted_sweep_leaves_nothing_running_or_half_written_and_resumes(sequence, tmp_path, sig):
    folder = tmp_path / "sweep"
    process = subprocess.Popen(
        sweep_command(sequence, folder),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while not list((folder / "records").glob("*.json")):
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, "no record was written in 120 s"
        time.sleep(0.1)
    process.send_signal(sig)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode in (128 + sig, -sig), stderr
    if sig != signal.SIGKILL:
        assert f"mmocap: interrupted by {sig.name}" in stderr, stderr
        assert f"hydra.sweep.dir={folder}" in stderr, stderr
        assert "Traceback" not in stderr
    # workers of a SIGKILLed sweep get SIGTERM from the kernel
    assert processes_left(process.pid) == [], "processes of the sweep are still running"
    before = records(folder)
    assert 1 <= len(before) < JOBS

    again = subprocess.run(sweep_command(sequence, folder), capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    after = records(folder)
    assert len(after) == JOBS
    assert all(after[run_id] == mtime for run_id, mtime in before.items()), "a finished run was run again"
    assert len(pd.read_csv(folder / "runs.csv")) == JOBS
    leftovers = [p for p in folder.rglob("*") if p.name.endswith((".tmp", ".partial")) or ".tmp" in p.name]
    assert leftovers == []
