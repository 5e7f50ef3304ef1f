"""A config file changed under a sweep: the sweep refuses with one line naming the file,
whether it changed while the jobs ran (each job checks, in the launcher's worker processes)
or before the sweep was resumed, and no job writes a record."""

from pathlib import Path

from tests.helpers import REPOSITORY, assert_clean_error, edit_after_sweep_start, mmocap, track_args
from tests.helpers import mmocap_in_process as mmocap_here

EXPERIMENT = "# @package _global_\ntracking:\n  evaluations: 60\n"


def user_experiment(tmp_path: Path) -> Path:
    """A user's own config folder (``--config-dir``) with ``experiment/mine.yaml``."""
    path = tmp_path / "myconf" / "experiment" / "mine.yaml"
    path.parent.mkdir(parents=True)
    path.write_text(EXPERIMENT)
    return path


def sweep_args(sequence: Path, sweep: Path, seeds: str, *extra: str) -> list[str]:
    """A multirun over ``seeds`` of the user's experiment on the sequence folder ``sequence``."""
    return [
        "-m",
        "--config-dir",
        str(sweep.parent / "myconf"),
        "+experiment=mine",
        f"seed={seeds}",
        *[a for a in track_args(sequence, sweep) if not a.startswith(("hydra.run.dir=", "tracking.evaluations="))],
        "overlays=0",
        f"hydra.sweep.dir={sweep}",
        *extra,
    ]


def records(sweep: Path) -> list[Path]:
    return sorted((sweep / "records").glob("*.json"))


def test_a_config_file_changed_while_the_jobs_run_stops_the_sweep(sequence_copy, tmp_path):
    """Two joblib workers: the file changes once the sweep has started, before any job runs."""
    mine = user_experiment(tmp_path)
    sweep = tmp_path / "sweep"
    outcome = mmocap(
        *sweep_args(sequence_copy, sweep, "0,1,2", "hydra.launcher.n_jobs=2"),
        *edit_after_sweep_start(mine),
        cwd=tmp_path,
        env={"PYTHONPATH": str(REPOSITORY)},
    )
    line = assert_clean_error(outcome, "myconf/experiment/mine.yaml changed since the sweep", "hydra.sweep.dir=")
    assert "undo the change and run the same command" in line
    assert records(sweep) == []


def test_a_sweep_resumed_after_its_config_file_changed_is_refused_before_any_job(sequence_copy, tmp_path):
    mine = user_experiment(tmp_path)
    sweep = tmp_path / "sweep"
    first = mmocap_here(*sweep_args(sequence_copy, sweep, "0", "hydra/launcher=basic"), cwd=tmp_path)
    assert first.code == 0, first
    finished = {p.name: p.read_bytes() for p in records(sweep)}
    assert len(finished) == 1

    mine.write_text(EXPERIMENT.replace("60", "70"))
    outcome = mmocap_here(*sweep_args(sequence_copy, sweep, "0,1", "hydra/launcher=basic"), cwd=tmp_path)
    assert_clean_error(outcome, "myconf/experiment/mine.yaml changed since the sweep")
    assert {p.name: p.read_bytes() for p in records(sweep)} == finished
    assert not (sweep / "1").exists()
