"""A tracking run's folder: the names of the files a run writes there, and its summary.

This module owns the run folder's layout; every writer and reader takes the names from here:

- :data:`SUMMARY` (``summary.json``): the run's :class:`Summary`, written last: a folder
  without it holds an unfinished run. :func:`read_summary` is its one reader.
- :data:`FRAMES` (``frames.csv``): one row per frame, written as it goes to
  :data:`FRAMES_PARTIAL` and renamed when the last frame is tracked.
- :data:`TRACES` (``traces.csv``): each frame's convergence (:mod:`mmocap.writers.traces`).
- :data:`ERROR_PLOT` (``error_per_frame.png``), :data:`OVERLAYS` (``overlays/frame_*.png``),
  :data:`VIDEOS` (``videos/<camera>.mp4``) and :data:`SKELETON_FILES`: the pictures
  (:mod:`mmocap.writers`).
- :data:`EXPORT_FOLDER` (``export/``): the motion files (:mod:`mmocap.writers.export`).
- :data:`RUN_LOCK` (``.run.lock``): held by the run writing into the folder.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from dataclasses import dataclass
from pathlib import Path

from mmocap.errors import DataError
from mmocap.io import read_json_object, write_json_atomic
from mmocap.validate import is_integer, is_real

#: the run's summary, written after every other output
SUMMARY = "summary.json"
#: one row per tracked frame; named FRAMES_PARTIAL until the run has tracked its last frame
FRAMES = "frames.csv"
FRAMES_PARTIAL = FRAMES + ".partial"
#: each frame's best fitness against the evaluations spent on it
TRACES = "traces.csv"
#: the marker error per frame, drawn when the sequence has ground truth
ERROR_PLOT = "error_per_frame.png"
#: the folder of the overlay images, ``frame_<frame, 6 digits>.png``
OVERLAYS = "overlays"
#: the folder of the per-camera videos (``video=true``)
VIDEOS = "videos"
#: the 3-D skeleton pictures (``video=true``): the strip of stick figures and its animation
SKELETON_FILES = ("skeleton.png", "skeleton.mp4")
#: the folder the motion files go to unless told otherwise
EXPORT_FOLDER = "export"
#: the lock file a run holds in its folder
RUN_LOCK = ".run.lock"
#: the files a run writes into its folder besides the overlays, videos and exports
RUN_OUTPUTS = (FRAMES, FRAMES_PARTIAL, TRACES, ERROR_PLOT, SUMMARY)
#: what every error about a summary.json tells the user to do
RUN_AGAIN = "that run did not finish: delete its folder or run it again"


@dataclass(kw_only=True)
class Summary:
    """A finished run's ``summary.json``, its keys in the order of the fields.

    Marker errors are in mm over the frames with ground truth (``frames_scored``), null if
    there is none; times in seconds. The fields with a default are absent from the summaries
    of older mmocap versions, and read as None there.
    """

    #: mean, median and largest marker error over the scored frames, mm (null: none scored)
    mean_marker_error_mm: float | None
    median_marker_error_mm: float | None
    max_marker_error_mm: float | None
    #: the mean over the frames of each frame's best fitness (0 = the model covers the foreground
    #: exactly, 1 = not at all; null if a frame's is not finite)
    mean_best_fitness: float | None = None
    #: frames tracked
    frames: int
    #: frames scored, over which the errors are taken: those with every ground-truth marker
    #: (:meth:`mmocap.data.sequence.SequenceBase.ground_truth`; with
    #: ``evaluation.missing_markers=score``, those with any)
    frames_scored: int | None = None
    #: the exact search's evaluations per frame
    evaluations_per_frame: int
    #: the cheaper fitness levels' evaluations per frame (:mod:`mmocap.stages.fidelity`)
    cheap_evaluations_per_frame: int | None = None
    #: evaluations of the whole run, every level and recovery included
    evaluations_used: int
    #: the search's wall time per frame, s (the foreground read apart)
    seconds_per_frame: float
    #: the time per frame spent reading the foreground, s
    foreground_seconds_per_frame: float | None = None
    #: optimiser and strategy names
    optimizer: str
    strategy: str
    #: degrees of freedom searched
    dof: int
    #: the backend that evaluated (``auto``'s choice), and the evaluator the config named
    backend: str
    evaluator_choice: str | None = None
    #: skin samples of the body model
    vertices: int
    #: the sequence's subject ("unknown" for a recording that names nobody)
    subject: str
    #: the body tracked with: preset, height_mm (mm) and girth (an automatic start fits them)
    body: dict | None = None
    #: how the first pose was found (:meth:`mmocap.stages.initialisation.Start.summary`)
    start: dict | None = None
    #: the 2-D keypoints in the fitness: source, skeleton, weight, how often each point was
    #: seen (:meth:`mmocap.stages.keypoints.KeypointStream.summary`); null: silhouettes only
    keypoints: dict | None = None
    #: the plausibility checks that failed (:meth:`mmocap.stages.plausibility.Plausibility.findings`)
    plausibility: list | None = None
    #: the recoveries (:meth:`mmocap.stages.recovery.RecoveryEvent.summary`)
    recoveries: list | None = None
    #: the sequence's action (null if it names none), camera names and folder
    action: str | None
    cameras: list
    sequence: str
    #: the sequence's frame rate, frames per second
    fps: float | None = None
    #: the run's seed and its key in the results store (:func:`mmocap.analysis.results.run_key`)
    seed: int
    run_id: str
    #: versions, commit, host and where the components come from (:mod:`mmocap.provenance`)
    provenance: dict
    #: the run's resolved config
    config: dict
    #: the messages of the warnings the run gave
    warnings: list | None = None

    def to_json(self) -> dict:
        """The summary as the JSON object of ``summary.json`` (its keys in field order)."""
        return {field.name: getattr(self, field.name) for field in dataclasses.fields(self)}

    @classmethod
    def from_json(cls, data: dict, source: str = SUMMARY) -> Summary:
        """The summary of a ``summary.json`` object; a DataError naming ``source`` and the
        keys that are missing, or the first of the wrong kind. Keys it does not know are
        ignored."""
        fields = dataclasses.fields(cls)
        missing = [f.name for f in fields if f.default is dataclasses.MISSING and f.name not in data]
        if missing:
            raise DataError(
                f"{source} lacks {', '.join(missing)}; it is not the summary of a finished tracking run: {RUN_AGAIN}"
            )
        hints = typing.get_type_hints(cls)
        for f in fields:
            if f.name in data and not _is_kind(data[f.name], hints[f.name]):
                raise DataError(f"{source}: {f.name} is {data[f.name]!r:.40}, not {_kind_name(hints[f.name])}")
        return cls(**{f.name: data[f.name] for f in fields if f.name in data})

    def write(self, folder: Path) -> Path:
        """Write the summary into the run folder ``folder`` atomically; returns its path."""
        return write_json_atomic(Path(folder) / SUMMARY, self.to_json())


#: a field's type -> how an error names it
_KIND_NAMES = {int: "an integer", float: "a number", str: "text", dict: "a JSON object", list: "a list"}


def _kinds(hint) -> tuple[list[type], bool]:
    """The types a field's type hint allows, and whether it allows null."""
    if isinstance(hint, types.UnionType):
        args = typing.get_args(hint)
        return [a for a in args if a is not type(None)], type(None) in args
    return [hint], False


def _is_kind(value, hint) -> bool:
    """Whether a JSON value is of a field's type (an int where a float is wanted too)."""
    kinds, nullable = _kinds(hint)
    if value is None:
        return nullable
    checks = {int: is_integer, float: is_real}
    return any(checks[k](value) if k in checks else isinstance(value, k) for k in kinds)


def _kind_name(hint) -> str:
    kinds, nullable = _kinds(hint)
    return " or ".join(_KIND_NAMES[k] for k in kinds) + (" or null" if nullable else "")


def summary_paths(folder: str | Path) -> list[Path]:
    """The ``summary.json`` of every finished run at or below ``folder``, in path order."""
    return sorted(Path(folder).rglob(SUMMARY))


def read_summary(folder: str | Path) -> Summary:
    """The :class:`Summary` of the run in ``folder``; a one-line DataError naming its
    ``summary.json`` when it is missing (an unfinished run), is not a JSON object, lacks a
    key or holds one of the wrong kind."""
    path = Path(folder) / SUMMARY
    if not path.is_file():
        raise DataError(f"{path} is missing: {Path(folder)} holds no finished run; run it again")
    return Summary.from_json(read_json_object(path, wanted="a run summary (a JSON object)", fix=RUN_AGAIN), str(path))
