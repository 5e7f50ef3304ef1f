"""A worker killed mid-job on a distributed engine: Ray (a local Ray cluster the test starts)
and SLURM's Submitit launcher (its local executor: there is no SLURM here). The sweep either
runs the job again or names it as unfinished; no process of it is left running, no record is
half-written, and the same command then runs exactly the missing jobs (tests/test_faults.py
holds the local launcher to the same)."""

import contextlib
import importlib.util
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from mmocap.analysis.results import load_runs
from mmocap.data.synthetic import generate
from mmocap.io import read_json_lines
from mmocap.run_folder import FRAMES_PARTIAL, RUN_LOCK, SUMMARY
from tests.helpers import TINY_BAD_INPUT as TINY
from tests.helpers import end_session, fault_sweep_command, processes_left, session_processes

JOBS = 3
#: the job whose worker is killed: it runs beside job 0, so that job 0 finishes either way
KILLED = 1

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc to find the processes")


@pytest.fixture(scope="module")
def sequence(tmp_path_factory) -> Path:
    return generate(tmp_path_factory.mktemp("engines") / "S1_walking", progress=False, **TINY)


def sweep_command(sequence: Path, folder: Path, *launcher: str) -> list[str]:
    """A sweep of JOBS runs of two frames each (about a second a frame) with ``launcher``."""
    return fault_sweep_command(sequence, folder, JOBS, *launcher)


def kill_mid_job(sweep: subprocess.Popen, job_dir: Path) -> int:
    """SIGKILL the process running the job of ``job_dir`` once it has tracked its first frame
    and before it ends (its run folder's lock names it); returns its pid."""
    deadline = time.monotonic() + 240
    while not (job_dir / FRAMES_PARTIAL).exists():
        assert sweep.poll() is None, sweep.communicate()
        assert time.monotonic() < deadline, f"{job_dir} tracked no frame in 240 s"
        time.sleep(0.02)
    pid = int(re.match(r"process (\d+) ", (job_dir / RUN_LOCK).read_text())[1])
    os.kill(pid, signal.SIGKILL)
    assert not (job_dir / SUMMARY).exists(), "the job ended before it was killed"
    return pid


def records(folder: Path) -> dict[str, int]:
    """run_id -> modification time of every record; each must be whole, and load_runs must
    read them all."""
    found = {}
    for path in sorted((folder / "records").glob("*.json")):
        record = json.loads(path.read_text())
        assert record["summary"]["frames"] == TINY["frames"], path
        found[path.stem] = path.stat().st_mtime_ns
    if found:
        runs, frames = load_runs(folder)
        assert sorted(runs["run_id"]) == sorted(found)
        assert len(frames) == len(found) * TINY["frames"]
    return found


def assert_nothing_half_written(folder: Path) -> None:
    """No temporary is left (a killed run's ``frames.csv.partial`` is one until a rerun tidies it)."""
    leftovers = [p for p in folder.rglob("*") if p.name.endswith((".tmp", ".partial")) or ".tmp" in p.name]
    assert leftovers == []


def assert_resumes_exactly_the_missing_jobs(command: list[str], folder: Path, before: dict, env: dict) -> None:
    """The same command again runs the jobs without a record, and no other (each job's line in
    ``progress.jsonl`` says whether it ran: the jobs' own logs stay with the engine)."""
    again = subprocess.run(command, capture_output=True, text=True, timeout=300, env=env, start_new_session=True)
    assert again.returncode == 0, again.stderr
    session = json.loads((folder / "sweep.json").read_text())["session"]
    ended = [line for line in read_json_lines(folder / "progress.jsonl") if line["session"] == session]
    assert sorted(line["job"] for line in ended) == list(range(JOBS))
    assert sum(line["ran"] for line in ended) == JOBS - len(before)
    after = records(folder)
    assert len(after) == JOBS
    assert all(after[run_id] == mtime for run_id, mtime in before.items()), "a finished run was run again"
    assert_nothing_half_written(folder)


# --- Ray ----------------------------------------------------------------------------------


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def running_jobs(session: int) -> list[int]:
    """The processes of the Ray cluster's session that run a sweep job (idle workers stay)."""
    jobs = []
    for pid in session_processes(session):
        with contextlib.suppress(OSError):
            if Path(f"/proc/{pid}/cmdline").read_bytes().startswith(b"ray::_run_job"):
                jobs.append(pid)
    return jobs


@pytest.fixture(scope="module")
def ray_cluster():
    """A Ray cluster on this machine: ``ray start --head`` on 127.0.0.1 with two CPUs, in a
    session of its own, ended with every process of that session (``ray stop`` would stop
    every Ray instance of the machine). Yields its address, session id and environment."""
    missing = [m for m in ("ray", "hydra_plugins.hydra_ray_launcher") if importlib.util.find_spec(m) is None]
    if missing:
        pytest.skip(f"Ray cannot start: {', '.join(missing)} not installed (pip install mmocap[ray])")
    temp = tempfile.mkdtemp(prefix="ray")  # short: Ray's socket paths must fit in 107 bytes
    env = {**os.environ, "RAY_AUTH_MODE": "disabled", "RAY_USAGE_STATS_ENABLED": "0", "HYDRA_FULL_ERROR": "0"}
    address = f"127.0.0.1:{free_port()}"
    start = subprocess.Popen(
        [sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--node-ip-address=127.0.0.1"]
        + [f"--port={address.split(':')[1]}", "--num-cpus=2", f"--temp-dir={temp}", "--include-dashboard=false"]
        + ["--disable-usage-stats", "--object-store-memory=78643200"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
        start_new_session=True,
    )
    try:
        output, _ = start.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        output = "no answer in 120 s"
    if start.returncode != 0:
        end_session(start.pid)
        shutil.rmtree(temp, ignore_errors=True)
        pytest.skip(f"Ray cannot start: `ray start --head` failed: {output.strip().splitlines()[-1:]}")
    yield address, start.pid, env
    end_session(start.pid)
    shutil.rmtree(temp, ignore_errors=True)
    assert session_processes(start.pid) == [], "processes of the Ray cluster are still running"


def run_killed_ray_sweep(sequence: Path, folder: Path, ray_cluster, *extra: str):
    """The sweep on the cluster, its job KILLED's worker SIGKILLed mid-job: (command, the
    finished sweep, its stderr, the killed pid)."""
    address, cluster, env = ray_cluster
    command = sweep_command(sequence, folder, "hydra/launcher=ray_cpu", f"hydra.launcher.ray.init.address={address}")
    command += list(extra)
    sweep = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, start_new_session=True
    )
    killed = kill_mid_job(sweep, folder / str(KILLED))
    _, stderr = sweep.communicate(timeout=300)
    assert session_processes(sweep.pid) == [], "processes of the sweep are still running"
    deadline = time.monotonic() + 30  # Ray ends the tasks of a driver that has exited
    while running_jobs(cluster) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert running_jobs(cluster) == [], "a job of the sweep is still running on the cluster"
    return command, sweep, stderr, killed


def test_a_ray_worker_killed_mid_job_runs_its_job_again(sequence, ray_cluster, tmp_path):
    folder = tmp_path / "sweep"
    command, sweep, stderr, killed = run_killed_ray_sweep(sequence, folder, ray_cluster)
    assert sweep.returncode == 0, stderr
    holder = (folder / str(KILLED) / RUN_LOCK).read_text()
    assert f"process {killed} " not in holder, "the killed job was not run again"
    finished = records(folder)
    assert len(finished) == JOBS
    assert_nothing_half_written(folder)
    assert_resumes_exactly_the_missing_jobs(command, folder, finished, ray_cluster[2])


def test_a_ray_job_out_of_retries_is_named_and_resumed(sequence, ray_cluster, tmp_path):
    folder = tmp_path / "sweep"
    command, sweep, stderr, _ = run_killed_ray_sweep(
        sequence, folder, ray_cluster, "hydra.launcher.ray.remote.max_retries=0"
    )
    assert sweep.returncode != 0
    assert "WorkerCrashedError" in stderr
    named = [line for line in stderr.splitlines() if "sweep jobs did not finish" in line]
    assert len(named) == 1, stderr
    assert f"#{KILLED} (seed={KILLED})" in named[0]
    assert f"hydra.sweep.dir={folder}" in named[0]
    before = records(folder)
    assert 1 <= len(before) < JOBS
    assert not list((folder / "records").glob("*.tmp"))
    assert_resumes_exactly_the_missing_jobs(command, folder, before, ray_cluster[2])


# --- SLURM (Submitit's local executor) -------------------------------------------------------


@pytest.mark.slow  # 45 s: each job, and each job of the resume, is a Python process of its own
@pytest.mark.skipif(
    importlib.util.find_spec("hydra_plugins.hydra_submitit_launcher") is None,
    reason="hydra-submitit-launcher not installed (pip install mmocap[slurm])",
)
def test_a_submitit_job_killed_mid_job_is_named_and_resumed(sequence, tmp_path):
    folder = tmp_path / "sweep"
    command = sweep_command(sequence, folder, "hydra/launcher=submitit_local", "hydra.launcher.timeout_min=5")
    env = {**os.environ, "HYDRA_FULL_ERROR": "0"}
    sweep = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, start_new_session=True
    )
    kill_mid_job(sweep, folder / str(KILLED))
    _, stderr = sweep.communicate(timeout=300)
    assert sweep.returncode != 0
    assert "UncompletedJobError" in stderr
    named = [line for line in stderr.splitlines() if "sweep jobs did not finish" in line]
    assert len(named) == 1, stderr
    assert f"#{KILLED} (seed={KILLED})" in named[0]
    # the local executor's job processes end with the sweep
    assert processes_left(sweep.pid) == [], "processes of the sweep are still running"
    before = records(folder)
    assert 1 <= len(before) < JOBS
    assert not list((folder / "records").glob("*.tmp"))
    assert_resumes_exactly_the_missing_jobs(command, folder, before, env)
