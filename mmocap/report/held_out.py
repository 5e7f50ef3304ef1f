"""The held-out camera: how well a finished run explains a camera it was not tracked with.

A recording of real people has no marker ground truth. What can be measured honestly is
agreement with a view the tracker never saw: track with all cameras but one, project the
tracked body into the one left out, and compare it there with that camera's own foreground
and 2-D landmarks (person segmentation's, :mod:`mmocap.stages.segmentation`):

- the silhouette IoU of the projected body with the camera's mask, per frame;
- the distance in pixels of the body's joints from the camera's landmarks
  (:data:`~mmocap.stages.segmentation.JOINT_LANDMARKS`), per joint, where the landmark's
  visibility is at least :data:`MIN_VISIBILITY`; also as a percentage of the person's height
  in the image (the mask's height), which does not depend on the camera's resolution.

Landmarks mark surface features, not joint centres (a hip landmark lies in front of and
inside the hip joint: docs/results/keypoint_offsets.md), so the joint distance has a floor
above zero even for a perfect track.

Command line::

    mmocap held-out RUN [RUN...] --camera NAME [--md FILE] [--page PAGE --target T --runs RUN...]

writes one row per frame to ``RUN/held_out_<camera>.csv`` and prints the summary table, with
a mean and a median column per RUN side by side (say, tracked with and without the keypoint
term); ``--md`` writes it too, and ``--page`` puts it on a stamped results page, after a table
of the runs: those of ``--runs`` and each RUN, with their times, fitness and body.
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

import numpy as np
import pandas as pd
from hydra.utils import instantiate
from omegaconf import OmegaConf
from tqdm.auto import tqdm

from mmocap.body.skeleton import JOINTS
from mmocap.errors import ConfigError, DataError
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.io import atomic_writer, write_text_atomic
from mmocap.pipeline import open_foreground
from mmocap.report.results_page import update_page
from mmocap.run_folder import FRAMES, read_summary
from mmocap.stages.segmentation import JOINT_LANDMARKS, LANDMARK_NAMES
from mmocap.writers.export import read_poses, run_body

log = logging.getLogger(__name__)

#: landmarks seen with less visibility than this are not compared
MIN_VISIBILITY = 0.5
#: joint groups of the summary table: name -> mmocap joints
JOINT_GROUPS = {
    "shoulders": ("LShoulder", "RShoulder"),
    "elbows": ("LElbow", "RElbow"),
    "wrists": ("LWrist", "RWrist"),
    "hips": ("LHip", "RHip"),
    "knees": ("LKnee", "RKnee"),
    "ankles": ("LAnkle", "RAnkle"),
}


def held_out_frames(run_dir: str | Path, camera: str, progress: bool = False) -> pd.DataFrame:
    """One row per tracked frame of the run in ``run_dir``, seen by ``camera``: ``frame``,
    ``iou`` (NaN where the camera's mask is empty), ``person_height_px`` (the mask's rows),
    and ``<joint>_px`` per joint of :data:`JOINT_LANDMARKS` (NaN where its landmark is
    missing or hardly visible), in pixels of the camera as the run read it.

    Raises:
        DataError: ``run_dir`` is not a finished run, or the camera is one it tracked with.
    """
    run_dir = Path(run_dir)
    summary = read_summary(run_dir)
    if camera in summary.cameras:
        raise DataError(
            f"camera {camera}: the run in {run_dir} was tracked with it ({', '.join(summary.cameras)}); "
            "hold a camera out of the run (dataset.cameras) to measure agreement with it"
        )
    cfg = OmegaConf.create(summary.config)
    cfg.dataset.cameras = [camera]
    sequence = instantiate(cfg.dataset).open(progress=False)
    foreground = open_foreground(cfg, sequence, cache_dir=cfg.foreground_cache)
    body = run_body(summary, run_dir / "summary.json")
    poses = read_poses(run_dir / FRAMES)
    evaluator = NumpyEvaluator()
    ideal = foreground.cameras[0]
    joints = [JOINTS.index(joint) for joint in JOINT_LANDMARKS]
    landmark_rows = [LANDMARK_NAMES.index(name) for name in JOINT_LANDMARKS.values()]
    rows = []
    for frame, pose in enumerate(tqdm(poses, desc=f"held-out {camera}", unit="frame", disable=not progress)):
        masks, landmarks = foreground.detections(frame)
        mask = np.asarray(masks[0])
        evaluator.setup(body, [ideal], [mask])
        model = evaluator.render(pose, 0)
        union = np.count_nonzero(model | mask)
        filled = np.flatnonzero(mask.any(axis=1))
        row = {
            "frame": frame,
            "iou": np.count_nonzero(model & mask) / union if mask.any() else np.nan,
            "person_height_px": float(filled[-1] - filled[0] + 1) if filled.size else np.nan,
        }
        uv = ideal.project(body.joint_positions(pose[None])[0][joints])
        seen = landmarks[0]
        for name, point, k in zip(JOINT_LANDMARKS, uv, landmark_rows):
            visible = seen is not None and seen[k, 2] >= MIN_VISIBILITY
            row[f"{name}_px"] = float(np.hypot(*(point - seen[k, :2]))) if visible else np.nan  # type: ignore[index]  # visible: landmarks
        rows.append(row)
    evaluator.close()
    return pd.DataFrame(rows)


def summary_table(frames: pd.DataFrame, camera: str) -> pd.DataFrame:
    """The per-frame rows of :func:`held_out_frames` summed up: one row per measure (IoU, each
    joint group, all joints), its mean and median (columns named after ``camera``, or a run),
    and the frames it was measured on."""
    height = frames["person_height_px"]
    measures = {"silhouette IoU": frames["iou"]}
    for group, names in JOINT_GROUPS.items():
        measures[f"{group} (px)"] = pd.concat([frames[f"{name}_px"] for name in names])
    every = [f"{name}_px" for name in JOINT_LANDMARKS]
    measures["all joints (px)"] = pd.concat([frames[c] for c in every])
    measures["all joints (% of person height)"] = pd.concat([100 * frames[c] / height for c in every])
    rows = [
        {
            "measure": name,
            f"mean ({camera})": values.mean(),
            f"median ({camera})": values.median(),
            "measured": int(values.notna().sum()),
            "of": len(values),
        }
        for name, values in measures.items()
    ]
    return pd.DataFrame(rows)


def side_by_side(tables: dict[str, pd.DataFrame], camera: str) -> pd.DataFrame:
    """The :func:`summary_table` of each run (by its name), their means and medians side by
    side; ``measured`` and ``of`` are the first run's."""
    names = list(tables)
    merged = tables[names[0]][["measure"]].copy()
    for name in names:
        table = tables[name]
        merged[f"mean ({camera}, {name})"] = table[f"mean ({camera}, {name})"].to_numpy()
        merged[f"median ({camera}, {name})"] = table[f"median ({camera}, {name})"].to_numpy()
    first = tables[names[0]]
    merged["measured"], merged["of"] = first["measured"].to_numpy(), first["of"].to_numpy()
    return merged


def runs_table(run_dirs: list[Path]) -> pd.DataFrame:
    """One row per finished run: its cameras, where its keypoints came from, frames, the
    automatic start's time and silhouette fitness, the body it fitted, the search's and the
    foreground's time per frame and the mean silhouette fitness of the frames' poses (the
    silhouettes' alone, so that runs with and without keypoints compare)."""
    rows = []
    for run_dir in run_dirs:
        summary = read_summary(run_dir)
        start, body, keypoints = summary.start or {}, summary.body or {}, summary.keypoints or {}
        fitness = keypoints.get("mean_silhouette_fitness", pd.read_csv(run_dir / FRAMES)["fitness"].mean())
        rows.append(
            {
                "run": Path(run_dir).name,
                "cameras": ", ".join(summary.cameras),
                "keypoints": keypoints.get("source", "none"),
                "frames": summary.frames,
                "start (s)": start.get("seconds", np.nan),
                "start fitness": start.get("silhouette_fitness", start.get("fitness", np.nan)),
                "body height (mm)": body.get("height_mm", np.nan),
                "girth": body.get("girth", np.nan),
                "search (s/frame)": summary.seconds_per_frame,
                "foreground (s/frame)": summary.foreground_seconds_per_frame,
                "mean fitness": float(fitness),
            }
        )
    return pd.DataFrame(rows)


def main(argv: list[str], prog: str) -> None:
    """``mmocap held-out RUN --camera NAME``: agreement of a finished run with a camera it was
    not tracked with (silhouette IoU, joint distance from the camera's landmarks)."""
    parser = argparse.ArgumentParser(prog=prog, description=main.__doc__)
    parser.add_argument("run", type=Path, nargs="+", help="finished tracking runs' folders, compared side by side")
    parser.add_argument("--camera", required=True, help="the held-out camera, of the runs' recording")
    parser.add_argument("--md", type=Path, help="also write the summary table here")
    parser.add_argument(
        "--runs", type=Path, nargs="*", default=[], help="runs to list beside RUN (times, fitness, body) on the page"
    )
    parser.add_argument("--page", type=Path, help="put the table on this stamped results page")
    parser.add_argument("--target", default="real-demo", help="the make target the page's stamp names")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    tables = {}
    for run in args.run:
        if not run.is_dir():
            raise ConfigError(f"run folder {run} not found")
        frames = held_out_frames(run, args.camera, progress=not args.no_progress)
        with atomic_writer(run / f"held_out_{args.camera}.csv", "w") as f:
            frames.to_csv(f, index=False, float_format="%.4f")
        tables[run.name] = summary_table(frames, f"{args.camera}, {run.name}")
    table = side_by_side(tables, args.camera).to_markdown(index=False, floatfmt=".3f")
    print(table)
    if args.md:
        write_text_atomic(args.md, table + "\n")
    if args.page:
        runs = runs_table([*args.runs, *args.run]).to_markdown(index=False, floatfmt=".3g")
        update_page(
            args.page,
            args.target,
            None,
            {"runs": runs, "held_out": table},
            replaced=["runs", "held_out"],
            order=["runs", "held_out"],
        )
