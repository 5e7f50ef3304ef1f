"""What the tests share besides fixtures: the tiny configurations, the ways to run the
command line, and the checks of what a user sees. (``conftest.py`` files hold fixtures only.)

Running the command line:

- :func:`mmocap`: ``python -m mmocap ARGS`` in a subprocess, as a user runs it (the one
  subprocess runner; for what only a fresh process shows: start-up, imports, signals,
  launchers, the environment);
- :func:`mmocap_in_process`: the same command through :func:`mmocap.cli.main` in this
  process, with both streams and the exit status captured the same way (a second or more
  faster per run; for a test of what the command says or writes);
- :func:`run_cli`: :func:`mmocap.cli.main` in this process, leaving the output to the test's
  ``capsys``; returns the exit status.
"""
from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path

#: the tiny synthetic sequence of the session fixture ``tiny_sequence`` (tests/conftest.py):
#: 4 frames, 3 cameras (two colour, one greyscale), 320x240
TINY = dict(subject="S1", action="walking", frames=4, cameras=("C1", "C2", "BW1"),
            width=320, height=240, background_frames=3, seed=5)

#: the tiny sequence that the bad-input corpus breaks copies of (``tiny_original``,
#: tests/bad_input/conftest.py) and the fault tests sweep over: 2 frames, 2 cameras (one
#: colour, one greyscale), 160x120
TINY_BAD_INPUT = dict(subject="S1", action="walking", frames=2, cameras=("C1", "BW1"), width=160, height=120,
                      background_frames=3, seed=3)


def overrides(root, **extra) -> list[str]:
    """Command-line overrides that select the :data:`TINY` sequence under ``root`` and track
    2 frames of it at 300 evaluations; ``extra`` adds or replaces overrides."""
    args = {
        "dataset.root": str(root), "dataset.frames": TINY["frames"],
        "dataset.cameras": "[" + ",".join(TINY["cameras"]) + "]",
        "dataset.all_cameras": "[" + ",".join(TINY["cameras"]) + "]",
        "dataset.width": TINY["width"], "dataset.height": TINY["height"],
        "dataset.background_frames": TINY["background_frames"], "dataset.seed": TINY["seed"],
        "progress": "false", "overlays": 1, "tracking.frames": 2, "tracking.evaluations": 300,
    }
    args.update(extra)
    return [f"{k}={v}" for k, v in args.items()]


def track_args(root: Path, out: Path) -> list[str]:
    """Overrides of a quick tracking run of the :data:`TINY_BAD_INPUT` sequence folder
    ``root`` into ``out``."""
    return ["dataset=folder", f"dataset.root={root}", f"dataset.subject={TINY_BAD_INPUT['subject']}",
            "evaluator=numpy", "body.vertices=1000", "tracking.evaluations=60", "overlays=1",
            "progress=false", "foreground_cache=null", f"hydra.run.dir={out}"]


@dataclass
class Outcome:
    """What the user saw: the exit status and both streams."""

    args: list[str]
    code: int
    stdout: str
    stderr: str

    @property
    def returncode(self) -> int:
        """The exit status, by the name :class:`subprocess.CompletedProcess` gives it."""
        return self.code

    def __str__(self) -> str:
        return (f"mmocap {' '.join(self.args)}\nexit status {self.code}\n"
                f"--- stderr ---\n{self.stderr[-3000:]}\n--- stdout ---\n{self.stdout[-1500:]}")


def mmocap(*args, cwd: Path | None = None, timeout: float = 600, env: dict | None = None) -> Outcome:
    """``python -m mmocap ARGS`` in a subprocess, as a user runs it; ``env`` adds variables."""
    args = [str(a) for a in args]
    environment = {**os.environ, "HYDRA_FULL_ERROR": "0", **(env or {})}
    done = subprocess.run([sys.executable, "-m", "mmocap", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, env=environment)
    return Outcome(args, done.returncode, done.stdout, done.stderr)


@contextlib.contextmanager
def _environment(env: dict):
    saved = {name: os.environ.get(name) for name in env}
    os.environ.update(env)
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def mmocap_in_process(*args, cwd: Path | None = None, timeout: float = 600, env: dict | None = None) -> Outcome:
    """``mmocap ARGS`` through :func:`mmocap.cli.main` in this process, seen as
    :func:`mmocap` sees it: both streams captured, the exit status of ``SystemExit`` (0 when
    it returns), and an uncaught exception as its traceback on stderr with status 1.
    ``timeout`` is not enforced (it is there so that both runners take the same arguments);
    every warning shows, as in a fresh process."""
    from mmocap.cli import main

    args = [str(a) for a in args]
    out, err = io.StringIO(), io.StringIO()
    with (_environment({"HYDRA_FULL_ERROR": "0", **(env or {})}), contextlib.chdir(cwd or os.getcwd()),
          warnings.catch_warnings(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err)):
        warnings.simplefilter("default")
        try:
            main(args)
            code = 0
        except SystemExit as exc:
            code = 0 if exc.code is None else exc.code if isinstance(exc.code, int) else 1
        except Exception:  # noqa: BLE001 - shown as a fresh process shows it
            traceback.print_exc(file=err)
            code = 1
    return Outcome(args, code, out.getvalue(), err.getvalue())


def run_cli(*args) -> int:
    """``mmocap ARGS`` in this process; returns its exit status (0 when it returns)."""
    from mmocap.cli import main

    try:
        main([str(a) for a in args])
    except SystemExit as exc:
        return 0 if exc.code is None else exc.code
    return 0


def assert_clean_error(outcome: Outcome, *culprits: str) -> str:
    """Exit status 2, no traceback, and one ``mmocap: error:`` line naming every culprit
    (case-insensitive); returns that line."""
    assert "Traceback" not in outcome.stderr, f"a traceback:\n{outcome}"
    assert outcome.code == 2, f"exit status {outcome.code}, expected 2:\n{outcome}"
    lines = [line for line in outcome.stderr.splitlines() if line.startswith("mmocap: error:")]
    assert len(lines) == 1, f"expected one 'mmocap: error:' line:\n{outcome}"
    for culprit in culprits:
        assert culprit.lower() in lines[0].lower(), f"the error does not name {culprit!r}:\n{outcome}"
    return lines[0]


def assert_warned(outcome: Outcome, summary: dict, *words: str) -> str:
    """Exit status 0, no traceback, a ``mmocap: warning:`` line naming every word, and the
    same warning in ``summary["warnings"]``; returns the line."""
    assert "Traceback" not in outcome.stderr, f"a traceback:\n{outcome}"
    assert outcome.code == 0, f"exit status {outcome.code}, expected 0:\n{outcome}"
    lines = [line for line in outcome.stderr.splitlines() if line.startswith("mmocap: warning:")
             and all(w.lower() in line.lower() for w in words)]
    assert lines, f"no warning naming {words}:\n{outcome}"
    recorded = [w for w in summary.get("warnings", []) if all(x.lower() in w.lower() for x in words)]
    assert recorded, f"summary.json does not record the warning {words}: {summary.get('warnings')}"
    return lines[0]
