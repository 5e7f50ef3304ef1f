"""Commands for users' recordings (layout: :mod:`mmocap.data.recording.reader`).

``mmocap check-recording DIR [overrides]`` opens the recording as a tracking run would
(``dataset=recording dataset.root=DIR`` plus Hydra ``overrides`` such as
``dataset.offsets={C2:3}`` or ``dataset.up=+z``) and prints what it found before a long run:
the calibration (file, format, units and how they were decided), each camera (source,
frames, frame rate, offset, resolution, position), the frames that will be tracked, where the
foreground will come from and why (the recording's masks, the empty-scene plate, or person
segmentation: :func:`mmocap.stages.foreground.choose_method`), the 2-D keypoint files (read
whole and checked: their skeleton, ``keypoints.skeleton`` or ``auto``, and frames), the ground
truth, and these sanity checks on the first frame:

- the foreground of every camera (fraction of the image): a camera that sees nobody, or
  nearly only foreground, has a wrong background or is out of sync;
- the foreground against the person's visual hull: the hull's height, which must be a
  person's, and the share of each camera's foreground that the hull (carved from every
  camera's) explains; foreground that no other camera confirms (compression noise, shadows, a
  second person) leaves it low;
- the calibration: the rays through the centres of the silhouettes must meet; the distance
  in pixels between each silhouette's centre and the projection of the point where they
  meet shows a camera whose calibration does not fit its images;
- the up axis: the person must stand upright in mmocap's world (y up), above the cameras'
  floor, else ``dataset.up`` is wrong.

Every finding that would spoil a run is a warning line; a recording that cannot be read at
all is one error line (exit 2).

``mmocap pose2sim-demo OUT [--wheel FILE]`` puts Pose2Sim's real demo recording, as it ships
in Pose2Sim's wheel on the package index (:data:`POSE2SIM_WHEEL`), in ``OUT/Demo_SinglePerson``:
four 1080x1920 videos at 60 fps of one person, 100 frames, and the lab's Qualisys calibration,
with no empty-scene plate (its Qualisys world has z up, which ``dataset.up=auto`` takes).

``mmocap to-recording SEQUENCE OUT [--cameras C1,C2] [--offsets C2=3,BW1=1] [--yaw DEG] [--units mm|m]
[--crf N]``
writes a sequence folder (a synthetic one: ``outputs/data/S1_walking``) in the recording
layout, ground truth included, to test the path from a user's files to a result.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import warnings
import zipfile
from pathlib import Path

import cv2
import numpy as np
from hydra.errors import ConfigCompositionException
from hydra.utils import instantiate
from omegaconf import OmegaConf

from mmocap import config
from mmocap.body.mesh import HEIGHT_RANGE_MM
from mmocap.data.keypoints import AUTO
from mmocap.data.recording.reader import write_recording
from mmocap.data.sequence import Sequence
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.pipeline import open_foreground
from mmocap.stages.foreground import Foreground
from mmocap.stages.initialisation import nearest_point_to_rays, person_hull, silhouette_rays

#: the wheel on the package index that ships Pose2Sim's demo, and the demo's folder in it
POSE2SIM_WHEEL = "pose2sim==0.10.49"
POSE2SIM_DEMO = "Pose2Sim/Demo_SinglePerson/"
#: foreground fractions of the image outside which a camera's first frame is suspect
FOREGROUND_RANGE = (0.001, 0.5)
#: the share of a camera's foreground the visual hull must explain (see the module docstring);
#: a clean foreground leaves only the voxels' rounding out
HULL_EXPLAINED_WARN = 0.6
#: pixels between a silhouette's centre and the projected meeting point of the rays that
#: suggest a calibration that does not fit the images (a person's centre, not a point)
REPROJECTION_WARN_PX = 40.0


def check_recording(root: str, overrides: list[str], out=print) -> dict:
    """Open the recording ``root`` with ``overrides`` and ``out`` the report, line by line;
    returns the facts found (for tests)."""
    try:
        cfg = config.compose(["dataset=recording", f"dataset.root={root}", "progress=false", *overrides])
    except ConfigCompositionException as exc:
        raise ConfigError(f"{' '.join(overrides)}: {str(exc).splitlines()[0]}") from None
    sequence = instantiate(cfg.dataset).open(progress=False)
    meta = sequence.meta
    out(f"recording {sequence.root}")
    out(f"  calibration {meta['calibration']}: translations in {meta['units']}, world up axis {meta['up']}")
    out(f"  {len(sequence.cameras)} camera(s):")
    for camera, source, offset in zip(sequence.cameras, sequence.sources, sequence.offsets):
        centre_m = camera.centre / 1000
        rate = f"{source.fps:g} fps" if source.fps else "no frame rate"
        out(
            f"    {camera.name}: {source.kind} {source.path} ({source.count} frames, {rate}, offset {offset}); "
            f"{camera.width}x{camera.height} {'colour' if camera.colour else 'greyscale'}, "
            f"focal {camera.focal:.0f} px, "
            f"at ({centre_m[0]:.2f}, {centre_m[1]:.2f}, {centre_m[2]:.2f}) m, "
            f"{np.linalg.norm(centre_m):.2f} m from the origin"
        )
    seconds = sequence.n_frames / sequence.fps
    out(
        f"  frames tracked: {sequence.n_frames} from frame {meta['start']} ({seconds:.1f} s at {sequence.fps:g} fps; "
        f"{meta['recorded_frames']} frames recorded after the offsets)"
    )
    if sequence.has_background:
        for camera, source, frames in zip(sequence.cameras, sequence.background_sources, sequence.background_frames):
            out(f"  background {camera.name}: {len(frames)} frames of {source.path}")
    else:
        out("  background: no empty-scene plate (no background/ folder, dataset.background not set)")
    if sequence.has_given_masks:
        for camera, source in zip(sequence.cameras, sequence.mask_sources):
            out(f"  masks {camera.name}: {source.kind} {source.path} ({source.count} masks)")
    keypoints = None
    if sequence.has_keypoints:
        keypoints = sequence.keypoint_files(OmegaConf.select(cfg, "keypoints.skeleton", default=AUTO))
        out(
            f"  keypoints: {keypoints.source}: {keypoints.skeleton} ({len(keypoints.joints)} joints), "
            f"{keypoints.n_frames} frames of {len(keypoints.cameras)} camera(s)"
        )
    else:
        out("  keypoints: none (no pose/<camera>_json/ folders, no keypoints.csv)")
    foreground = open_foreground(cfg, sequence, cache_dir=None)
    out(f"  foreground: {foreground.method}")
    chosen, why = instantiate(cfg.keypoints).choose(sequence, foreground)
    out(f"  keypoints in the fitness: {chosen} ({why})")
    truth = sequence.markers()
    scored = int((~np.isnan(truth).any(axis=2)).any(axis=1).sum())
    out(
        f"  ground truth: {sequence.markers_source}: {scored} of {sequence.n_frames} frames have markers"
        if sequence.markers_path
        else "  ground truth: none (no markers_mm.csv): runs report no marker error"
    )
    facts = {
        "cameras": [c.name for c in sequence.cameras],
        "frames": sequence.n_frames,
        "fps": sequence.fps,
        "frames_with_markers": scored,
        "keypoints": None if keypoints is None else {"skeleton": keypoints.skeleton, "frames": keypoints.n_frames},
    }
    facts["foreground_method"] = foreground.method
    facts.update(_first_frame_checks(foreground, float(cfg.start.voxel_mm), out))
    return facts


def _first_frame_checks(foreground: Foreground, voxel_mm: float, out) -> dict:
    """The foreground, hull, calibration and up-axis checks of the module docstring on frame 0."""
    cameras, masks = foreground.cameras, foreground.masks(0)
    fractions = {}
    for camera, mask in zip(cameras, masks):
        fraction = float(np.count_nonzero(mask)) / mask.size
        fractions[camera.name] = fraction
        note = ""
        if not FOREGROUND_RANGE[0] <= fraction <= FOREGROUND_RANGE[1]:
            note = " <- suspect"
            warnings.warn(
                f"camera {camera.name}: the foreground of the first frame is {100 * fraction:.2f} % of the "
                "image: nobody in view, or a background that does not fit (check background, offsets)",
                MmocapWarning,
                stacklevel=2,
            )
        out(f"  first frame, camera {camera.name}: foreground {100 * fraction:.2f} % of the image{note}")
    explained = _hull_explained(cameras, masks, voxel_mm, out)
    centres, directions = silhouette_rays(cameras, masks)
    meet = nearest_point_to_rays(centres, directions)
    errors = {}
    for camera, mask in zip(cameras, masks):
        rows, cols = np.nonzero(np.asarray(mask))
        if rows.size == 0:
            continue
        errors[camera.name] = float(np.hypot(*(camera.project(meet[None])[0] - (cols.mean(), rows.mean()))))
    out(
        f"  the silhouettes' rays meet at ({meet[0] / 1000:.2f}, {meet[1] / 1000:.2f}, {meet[2] / 1000:.2f}) m; "
        "distance of each silhouette's centre from that point's image: "
        + ", ".join(f"{name} {px:.1f} px" for name, px in errors.items())
    )
    for name, px in errors.items():
        if px > REPROJECTION_WARN_PX:
            warnings.warn(
                f"camera {name}: its silhouette lies {px:.0f} px from where the other cameras place the "
                "person: its calibration may not fit its images (another camera's? wrong units?), or it is "
                "out of sync (dataset.offsets)",
                MmocapWarning,
                stacklevel=2,
            )
    camera_heights = np.array([c.centre[1] for c in cameras])
    if meet[1] < 0 or np.median(camera_heights) < 0:
        warnings.warn(
            f"the person's centre is {meet[1] / 1000:.2f} m and the cameras' median height "
            f"{np.median(camera_heights) / 1000:.2f} m above the floor along +y: is the world's up axis "
            "another one? set dataset.up (e.g. +z)",
            MmocapWarning,
            stacklevel=2,
        )
    return {
        "foreground_fraction": fractions,
        "hull_explained": explained,
        "reprojection_px": errors,
        "meeting_point_mm": meet.tolist(),
    }


def _hull_explained(cameras, masks, voxel_mm: float, out) -> dict:
    """Per camera, the fraction of its first-frame foreground covered by the projection of the
    person's visual hull (:func:`mmocap.stages.initialisation.person_hull`, voxels of side
    ``voxel_mm``); a warning where it is below :data:`HULL_EXPLAINED_WARN`."""
    try:
        hull = person_hull(cameras, masks, voxel_mm)
    except DataError as exc:
        warnings.warn(f"no visual hull in the first frame: {exc}", MmocapWarning, stacklevel=2)
        return {}
    height = float(np.ptp(hull[:, 1]) + voxel_mm)
    explained = {}
    for camera, mask in zip(cameras, masks):
        mask = np.asarray(mask)
        if not mask.any():
            continue
        depth = hull @ camera.R[2] + camera.t[2]
        uv = camera.project(hull)
        drawn = np.zeros(mask.shape, np.uint8)
        for (u, v), side in zip(uv, camera.focal * voxel_mm / depth):
            half = max(side / 2, 0.5)
            cv2.rectangle(drawn, (int(u - half), int(v - half)), (int(u + half), int(v + half)), 1, thickness=-1)
        explained[camera.name] = float(np.count_nonzero(mask & drawn.astype(bool)) / np.count_nonzero(mask))
    out(
        f"  first frame: the person's visual hull is {height:.0f} mm tall and explains "
        + ", ".join(f"{name} {100 * share:.0f} %" for name, share in explained.items())
        + " of each camera's foreground"
    )
    if not HEIGHT_RANGE_MM[0] <= height <= HEIGHT_RANGE_MM[1]:
        warnings.warn(
            f"the person's visual hull in the first frame is {height:.0f} mm tall, outside a person's "
            f"{HEIGHT_RANGE_MM[0]:.0f}-{HEIGHT_RANGE_MM[1]:.0f} mm: the foreground holds more (or less) than the "
            "person (compression noise, shadows, a background that does not fit); try another foreground "
            "(foreground.method, background=...)",
            MmocapWarning,
            stacklevel=2,
        )
    for name, share in explained.items():
        if share < HULL_EXPLAINED_WARN:
            warnings.warn(
                f"camera {name}: only {100 * share:.0f} % of its first-frame foreground lies inside the person's "
                f"visual hull (under {100 * HULL_EXPLAINED_WARN:.0f} %): the rest is seen by no other camera "
                "(compression noise, shadows, a second person, a wrong calibration); try another foreground "
                "(foreground.method, background=...) and check the masks",
                MmocapWarning,
                stacklevel=2,
            )
    return explained


def check_main(argv: list[str], prog: str) -> None:
    """``mmocap check-recording ROOT [OVERRIDES]``: check a recording folder before tracking it."""
    parser = argparse.ArgumentParser(
        prog=prog,
        description="Check a recording folder before tracking it: "
        "what it holds, and the first frame's foreground, calibration and up axis.",
    )
    parser.add_argument("root", help="the recording folder")
    parser.add_argument("overrides", nargs="*", help="Hydra overrides, e.g. dataset.offsets={C2:3} dataset.up=+z")
    args = parser.parse_args(argv)
    check_recording(args.root, args.overrides)


def _offsets(text: str) -> dict:
    """``"C2=3,BW1=1"`` -> {"C2": 3, "BW1": 1}; a ConfigError naming --offsets otherwise."""
    offsets = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, _, value = item.partition("=")
        if not name or not value.strip().isdigit():
            raise ConfigError(f"--offsets {text!r}: give CAMERA=FRAMES pairs separated by commas, e.g. C2=3,BW1=1")
        offsets[name.strip()] = int(value)
    return offsets


def convert_main(argv: list[str], prog: str) -> None:
    """``mmocap to-recording SEQUENCE OUT``: write a sequence folder as a user's recording
    (OpenCV YAML calibration, MP4 videos)."""
    parser = argparse.ArgumentParser(
        prog=prog,
        description="Write a sequence folder (with ground truth) in the "
        "layout of a user's recording: OpenCV YAML calibration, MP4 videos.",
    )
    parser.add_argument("sequence", type=Path, help="a sequence folder (the one holding sequence.json)")
    parser.add_argument("out", type=Path, help="the recording folder to write")
    parser.add_argument("--cameras", default=None, help="cameras to write, e.g. C1,C2,C3,BW1 (default: all)")
    parser.add_argument("--offsets", default="", help="frames of empty scene before a camera's video, e.g. C2=3")
    parser.add_argument("--yaw", type=float, default=0.0, help="turn the world about the vertical by DEG degrees")
    parser.add_argument("--units", choices=("mm", "m"), default="mm", help="units of the calibration's translations")
    parser.add_argument(
        "--crf",
        type=int,
        default=0,
        help="H.264 quality of the videos: 0 (default) lossless, 16 good, 23 ffmpeg's default; "
        "compressed videos are harder for the background models",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    cameras = None if args.cameras is None else [c.strip() for c in args.cameras.split(",") if c.strip()]
    sequence = Sequence.open(args.sequence, cameras)
    out = write_recording(
        sequence,
        args.out,
        offsets=_offsets(args.offsets),
        yaw_deg=args.yaw,
        units=args.units,
        crf=args.crf,
        progress=not args.no_progress,
    )
    print(
        f"recording written to {out}; track it with: mmocap track dataset=recording dataset.root={out}"
        + (
            f" dataset.offsets={{{','.join(f'{k}:{v}' for k, v in _offsets(args.offsets).items())}}}"
            if args.offsets
            else ""
        )
    )


def fetch_pose2sim_demo(out: Path, wheel: Path | None = None) -> Path:
    """``out/Demo_SinglePerson``: Pose2Sim's demo recording (module docstring), extracted from
    ``wheel`` or from the wheel downloaded with pip; kept once complete (a ``.complete`` file
    says so), so that a second call downloads nothing. A DataError when it cannot be had."""
    target = Path(out) / POSE2SIM_DEMO.rstrip("/").rsplit("/", 1)[-1]
    if (target / ".complete").is_file():
        return target
    with tempfile.TemporaryDirectory() as tmp:
        if wheel is None:
            command = [sys.executable, "-m", "pip", "download", "--no-deps", "--quiet", POSE2SIM_WHEEL, "-d", tmp]
            done = subprocess.run(command, capture_output=True, text=True, check=False)
            found = sorted(Path(tmp).glob("pose2sim-*.whl"))
            if done.returncode or not found:
                reason = " ".join((done.stderr or done.stdout).split())[-300:]
                raise DataError(
                    f"cannot download {POSE2SIM_WHEEL} from the package index ({reason}); download it "
                    "elsewhere with `pip download --no-deps " + POSE2SIM_WHEEL + "` and pass --wheel FILE"
                )
            wheel = found[0]
        try:
            with zipfile.ZipFile(wheel) as archive:
                members = [m for m in archive.namelist() if m.startswith(POSE2SIM_DEMO)]
                if not members:
                    raise DataError(f"{wheel} holds no {POSE2SIM_DEMO}: is it the wheel of {POSE2SIM_WHEEL}?")
                archive.extractall(tmp, members)
        except (zipfile.BadZipFile, OSError) as exc:
            raise DataError(f"{wheel} is not a readable wheel ({exc}); download it again") from None
        if target.exists():
            shutil.rmtree(target)  # an extraction that stopped
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(Path(tmp) / POSE2SIM_DEMO), target)
    (target / ".complete").write_text(f"{POSE2SIM_WHEEL}\n")
    return target


def pose2sim_demo_main(argv: list[str], prog: str) -> None:
    """``mmocap pose2sim-demo OUT``: put Pose2Sim's real demo recording in OUT/Demo_SinglePerson."""
    parser = argparse.ArgumentParser(prog=prog, description=pose2sim_demo_main.__doc__)
    parser.add_argument("out", type=Path, help="the folder to put Demo_SinglePerson in")
    parser.add_argument("--wheel", type=Path, help=f"the wheel of {POSE2SIM_WHEEL}, already downloaded")
    args = parser.parse_args(argv)
    if args.wheel is not None and not args.wheel.is_file():
        raise ConfigError(f"--wheel {args.wheel}: no such file")
    print(f"Pose2Sim's demo recording: {fetch_pose2sim_demo(args.out, args.wheel)}")
