"""Definition offsets of MediaPipe's landmarks, measured on synthetic data.

A detector's joint is not always the model's joint centre: a hip landmark lies in front of
the hip's centre, a shoulder landmark on the shoulder's surface. Where MediaPipe Pose (the
person segmenter's landmarks, :mod:`mmocap.stages.segmentation`) puts each landmark mapped
onto a model point (:data:`mmocap.data.skeletons.MAPPINGS`) is measured here, on sequences
whose poses and body are known:

1. synthetic sequences at ``realism=exact`` (the calibration is the true cameras, the body
   the preset's, ``BodyModel(subject)``), every camera (``dataset.all_cameras``), rendered
   or reused under ``dataset.root``;
2. person segmentation of every image (``foreground.segmentation``), its landmarks in the
   ideal pin-hole cameras, cached with the masks (``foreground_cache``);
3. each mapped landmark triangulated per frame (:func:`mmocap.stages.keypoint_start.triangulate`,
   confidence = MediaPipe's visibility, RANSAC within ``start.keypoint_inlier_px``);
4. each triangulated point ``p`` expressed in the rest frame of its model point's joint on
   the true pose, ``q = S_j^-1 p`` with ``S_j = body.transforms(true pose)[j]``; the offset is
   ``q`` minus the model point's rest position, mm, x to the subject's left, y up, z forward.

Per landmark the table gives the median offset per axis over every frame and sequence, its
length, the spread about it (the median and the rms 3-D distance of the frames' offsets from
it), how many frames gave a point, and the median distance of the points from the model
point without an offset and with the mapping's offset (as it stands when the command runs).
A second table gives the median offset per sequence, which shows whether it depends on the
motion.

Command line (``make keypoint-offsets``)::

    mmocap keypoint-offsets [--frames N] [--subjects S1,S2] [--page PAGE] [OVERRIDES]

``OVERRIDES`` are Hydra overrides of ``conf/config.yaml`` (``dataset.root=...``,
``foreground_cache=...``) applied to every sequence.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd
from hydra.errors import ConfigCompositionException
from hydra.utils import instantiate
from tqdm.auto import tqdm

from mmocap import config
from mmocap.body.keypoints import model_points
from mmocap.body.model import BodyModel
from mmocap.data.skeletons import skeleton_joints
from mmocap.data.synthetic import SyntheticDataset
from mmocap.errors import ConfigError
from mmocap.pipeline import open_foreground
from mmocap.report.results_page import update_page
from mmocap.stages.keypoint_start import triangulate
from mmocap.stages.keypoints import SkeletonMap

#: the skeleton measured: MediaPipe Pose's, the only detector that runs here
SKELETON = "MEDIAPIPE_33"
#: the synthetic actions measured per subject
ACTIONS = ("walking", "gestures", "boxing")
#: the overrides every measured sequence is composed with (see the module docstring)
SEQUENCE_OVERRIDES = ("realism=exact", "dataset.cameras=${dataset.all_cameras}", "foreground.method=segmentation")


def rest_frame_offsets(body, poses: np.ndarray, names, points: np.ndarray) -> np.ndarray:
    """World points expressed in the rest frame of their model points' joints, less the
    model points' rest positions.

    Args:
        body (BodyModel): the body the poses move.
        poses: (n, 51) true poses (mm, rad).
        names: K model point names (:data:`mmocap.body.keypoints.MODEL_POINTS`).
        points: (n, K, 3) world positions, mm (NaN where not found).

    Returns:
        (n, K, 3) offsets, mm, in the model's rest frame (x to the subject's left, y up, z
        forward); NaN where ``points`` is.
    """
    joint, rest = model_points(body, names)
    inverse = np.linalg.inv(body.transforms(np.asarray(poses, np.float64))[:, joint])
    q = np.einsum("nkab,nkb->nka", inverse[..., :3, :3], np.asarray(points, np.float64)) + inverse[..., :3, 3]
    return q - rest


def triangulated_landmarks(
    foreground, mapped: SkeletonMap, inlier_px: float, frames, progress: bool = False, label: str = ""
) -> np.ndarray:
    """(n, K, 3) mm the landmarks ``mapped.rows`` triangulated in each frame of ``frames``
    (n indices) from those ``foreground.detections`` finds in its ideal cameras (NaN where
    fewer than two cameras agree within ``inlier_px`` px, or nobody was found)."""
    points = []
    for frame in tqdm(frames, desc=f"landmarks {label}".strip(), unit="frame", disable=not progress):
        _, landmarks = foreground.detections(frame)
        observed = np.zeros((len(landmarks), len(mapped.rows), 3))
        for c, found in enumerate(landmarks):
            if found is not None:
                observed[c] = found[mapped.rows]
        points.append(triangulate(foreground.cameras, observed, inlier_px)[0])
    return np.array(points).reshape(-1, len(mapped.rows), 3)


def sequence_config(subject: str, action: str, frames: int | None, overrides=()):
    """The composed config of one measured sequence: ``SEQUENCE_OVERRIDES``, the subject and
    action, ``dataset.frames`` (None: the default) and the user's ``overrides``."""
    length = [] if frames is None else [f"dataset.frames={frames}"]
    try:
        return config.compose(
            [*SEQUENCE_OVERRIDES, f"dataset.subject={subject}", f"dataset.action={action}", *length, *overrides]
        )
    except ConfigCompositionException as exc:
        raise ConfigError(
            f"keypoint-offsets: {str(exc).splitlines()[0]} (the overrides apply to every synthetic sequence measured)"
        ) from None


def measure_sequence(cfg, mapped: SkeletonMap, progress: bool = False) -> np.ndarray:
    """(frames, K, 3) mm the offsets (:func:`rest_frame_offsets`) of the landmarks
    ``mapped`` in every frame of the synthetic sequence of ``cfg`` (rendered if needed).

    Raises:
        ConfigError: ``cfg`` is not a synthetic sequence at ``realism=exact``, whose body is
            the preset's.
    """
    dataset = instantiate(cfg.dataset)
    if not isinstance(dataset, SyntheticDataset) or dataset.realism.name != "exact":
        raise ConfigError(
            "keypoint-offsets measures on synthetic sequences at realism=exact, whose body is the preset's; "
            f"drop the dataset or realism override (got {cfg.dataset._target_}, realism {cfg.realism.name})"
        )
    sequence = dataset.open(progress=progress)
    foreground = open_foreground(cfg, sequence, cache_dir=cfg.foreground_cache)
    poses = np.load(sequence.root / "poses.npy")
    label = f"{sequence.subject} {sequence.meta.get('action')}"
    inlier_px = float(cfg.start.keypoint_inlier_px)
    points = triangulated_landmarks(foreground, mapped, inlier_px, range(sequence.n_frames), progress, label)
    return rest_frame_offsets(BodyModel(sequence.subject), poses[: sequence.n_frames], mapped.points, points)


def offsets_table(offsets: dict[str, np.ndarray], mapped: SkeletonMap) -> pd.DataFrame:
    """One row per landmark of ``mapped`` over the sequences' ``offsets`` ((frames, K, 3) mm
    each, by sequence): its model point, the median offset (x, y, z, length, mm), the median
    and rms 3-D distance of the frames' offsets from it (mm), the frames measured (``n``) of
    all (``of``), and the median distance (mm) of the triangulated points from the model
    point without an offset and with ``mapped.offsets_mm``."""
    every = np.concatenate(list(offsets.values()))
    joints = skeleton_landmarks(mapped)
    rows = []
    for k, (landmark, point) in enumerate(zip(joints, mapped.points)):
        found = every[:, k][np.isfinite(every[:, k]).all(axis=1)]
        median = np.median(found, axis=0) if len(found) else np.full(3, np.nan)
        spread = np.linalg.norm(found - median, axis=1)
        rows.append(
            {
                "landmark": landmark,
                "model point": point,
                "x (mm)": median[0],
                "y (mm)": median[1],
                "z (mm)": median[2],
                "length (mm)": float(np.linalg.norm(median)),
                "median spread (mm)": np.median(spread) if len(found) else np.nan,
                "rms spread (mm)": np.sqrt(np.mean(spread**2)) if len(found) else np.nan,
                "n": len(found),
                "of": len(every),
                "distance, no offset (mm)": np.median(np.linalg.norm(found, axis=1)) if len(found) else np.nan,
                "distance, mapping's offset (mm)": (
                    np.median(np.linalg.norm(found - mapped.offsets_mm[k], axis=1)) if len(found) else np.nan
                ),
            }
        )
    return pd.DataFrame(rows)


def by_sequence_table(offsets: dict[str, np.ndarray], mapped: SkeletonMap) -> pd.DataFrame:
    """One row per landmark, one column per sequence: its median offset ``x, y, z`` (mm,
    whole) over that sequence's frames, and the frames measured."""
    table = pd.DataFrame({"landmark": skeleton_landmarks(mapped)})
    for name, values in offsets.items():
        cells = []
        for k in range(len(mapped.points)):
            found = values[:, k][np.isfinite(values[:, k]).all(axis=1)]
            median = np.median(found, axis=0) if len(found) else np.full(3, np.nan)
            cells.append(f"{median[0]:.0f}, {median[1]:.0f}, {median[2]:.0f} ({len(found)})")
        table[name] = cells
    return table


def skeleton_landmarks(mapped: SkeletonMap) -> list[str]:
    """The detector joint names of ``mapped``'s rows, in its order."""
    joints = skeleton_joints(mapped.skeleton)
    return [joints[row] for row in mapped.rows]


def _subjects(text: str) -> list[str]:
    """``"S1,S2"`` -> ["S1", "S2"]; a ConfigError naming --subjects for an empty name."""
    subjects = [s.strip() for s in text.split(",")]
    if "" in subjects:
        raise ConfigError(f"--subjects {text!r} has an empty name; give comma-separated subjects, e.g. S1,S2")
    return list(dict.fromkeys(subjects))


def main(argv: list[str], prog: str) -> None:
    """``mmocap keypoint-offsets [--frames N] [--page PAGE] [OVERRIDES]``: where MediaPipe's
    landmarks lie relative to the model's points, measured on synthetic sequences."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=None, help="frames per sequence (default: dataset.frames)")
    parser.add_argument("--subjects", default="S1", help="comma-separated subjects, each with every action (S1)")
    parser.add_argument("--page", type=Path, help="put the tables on this stamped results page")
    parser.add_argument("--target", default="keypoint-offsets", help="the make target the page's stamp names")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    parser.add_argument("overrides", nargs="*", help="Hydra overrides, e.g. dataset.root=outputs/data")
    args = parser.parse_intermixed_args(argv)
    if args.frames is not None and args.frames < 1:
        raise ConfigError(f"--frames {args.frames}: give at least 1 frame per sequence")
    mapped = SkeletonMap.of(SKELETON)
    offsets = {}
    for subject in _subjects(args.subjects):
        for action in ACTIONS:
            cfg = sequence_config(subject, action, args.frames, args.overrides)
            offsets[f"{subject} {action}"] = measure_sequence(cfg, mapped, progress=not args.no_progress)
    frames = sum(len(values) for values in offsets.values())
    cameras = len(cfg.dataset.all_cameras)
    what = (
        f"MediaPipe Pose's landmarks triangulated from {cameras} cameras at {cfg.dataset.width}x{cfg.dataset.height} "
        f"over {frames} frames of {', '.join(offsets)} (realism exact), in the rest frame of their model point's joint "
        "on the true pose: offsets from the model point, mm, x to the subject's left, y up, z forward"
    )
    table = f"{what}.\n\n" + offsets_table(offsets, mapped).to_markdown(index=False, floatfmt=".1f")
    sequences = "Median offset x, y, z (mm) per sequence, and the frames measured.\n\n"
    sequences += by_sequence_table(offsets, mapped).to_markdown(index=False)
    print(table, sequences, sep="\n\n")
    if args.page:
        update_page(
            args.page,
            args.target,
            None,
            {"offsets": table, "by_sequence": sequences},
            replaced=["offsets", "by_sequence"],
            order=["offsets", "by_sequence"],
        )
