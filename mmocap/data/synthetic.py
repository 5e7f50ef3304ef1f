"""Synthetic HumanEva-like sequences: cameras, motion, rendering, ground truth on disk.

Defaults mimic HumanEva-I: 7 cameras (C1..C3 colour, BW1..BW4 greyscale) on a ring of
about 4 m around the capture volume, 640x480 at 60 fps, a little lens distortion.  The
images are rendered from the full MakeHuman triangle mesh posed by linear blend skinning
(:mod:`mmocap.data.render`), with clothing colours, shading, a cluttered background, the
person's soft shadow on the floor, lighting flicker and sensor noise; the tracker instead
uses rigidly attached surface samples, so the data is not made by the tracker's own model.
Layout on disk: :mod:`mmocap.data.sequence`.
"""

from __future__ import annotations

import hashlib
import json
import logging
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from mmocap.body.kinematics import global_transforms, skinning_transforms
from mmocap.body.mesh import SkinMesh, fit_subject, load_makehuman, subject_dimensions
from mmocap.body.model import MARKER_NAMES, marker_vertices, rest_frames
from mmocap.body.skeleton import JOINTS
from mmocap.camera import Camera
from mmocap.data import realism as realism_draws
from mmocap.data import render
from mmocap.data.keypoints import openpose_path, write_openpose_json
from mmocap.data.motion import generate_motion
from mmocap.data.realism import EXACT, Realism
from mmocap.data.sequence import FORMAT, Sequence, write_markers
from mmocap.errors import ConfigError, DataError
from mmocap.io import read_json_object, write_image, write_text_atomic, writing
from mmocap.validate import check_number

log = logging.getLogger(__name__)

# name, colour sensor, azimuth in degrees: the first four are spread evenly so that the
# usual 4-camera subset (C1, C2, C3, BW1) surrounds the subject.
CAMERA_RING = (
    ("C1", True, 20),
    ("C2", True, 110),
    ("C3", True, 200),
    ("BW1", False, 290),
    ("BW2", False, 65),
    ("BW3", False, 155),
    ("BW4", False, 245),
)


def camera_rig(
    names, width: int, height: int, rng: np.random.Generator, radius_mm: float = 4000.0, distortion: float = 1.0
) -> list[Camera]:
    """Cameras on a ring looking at the centre of the capture volume (y up, mm).

    ``distortion`` scales the lens distortion (0 gives ideal pin-holes). The focal length
    keeps a 640x480 image's field of view inside any ``width`` x ``height``: an image of
    another shape sees more at its sides (16:9) or above and below, never less, so the
    person stays in view.
    """
    ring = {name: (colour, az) for name, colour, az in CAMERA_RING}
    unknown = [n for n in names if n not in ring]
    if unknown:
        raise ConfigError(f"unknown camera {', '.join(unknown)}; known: {', '.join(ring)}")
    cameras = []
    for name in names:
        colour, azimuth = ring[name]
        az = np.deg2rad(azimuth + rng.uniform(-5, 5))
        r = radius_mm * rng.uniform(0.93, 1.07)
        eye = (r * np.sin(az), rng.uniform(1700, 2300), r * np.cos(az))
        target = (rng.uniform(-150, 150), 950, rng.uniform(-150, 150))
        focal = rng.uniform(580, 640) * min(width / 640, height / 480)
        dist = distortion * np.array(
            [
                rng.uniform(-0.25, -0.15),
                rng.uniform(0.05, 0.15),
                rng.uniform(-1e-3, 1e-3),
                rng.uniform(-1e-3, 1e-3),
                0.0,
            ]
        )
        cameras.append(Camera.look_at(name, eye, target, focal, width, height, dist, colour))
    return cameras


def face_colours(mesh: SkinMesh, rng: np.random.Generator) -> np.ndarray:
    """(F, 3) RGB in [0, 1]: shirt, trousers, shoes, skin and hair by body part."""
    joint_of = {j: n for n, j in enumerate(JOINTS)}
    face_joint = np.argmax(mesh.weights[mesh.faces].sum(axis=1), axis=1)
    shirt = rng.uniform(0.15, 0.8, 3)
    trousers = rng.uniform(0.1, 0.35, 3)
    skin = np.array([0.87, 0.67, 0.55]) * rng.uniform(0.6, 1.05)
    parts = {
        "shirt": (("BottomSpine", "UpperSpine", "LShoulder", "RShoulder"), shirt),
        "trousers": (("Root", "LHip", "RHip", "LKnee", "RKnee"), trousers),
        "shoes": (("LAnkle", "RAnkle"), np.array([0.12, 0.1, 0.1])),
        "skin": (("LElbow", "RElbow", "LWrist", "RWrist", "Neck"), skin),
    }
    colours = np.zeros((len(mesh.faces), 3))
    for joints, colour in parts.values():
        colours[np.isin(face_joint, [joint_of[j] for j in joints])] = colour
    centre = mesh.vertices[mesh.faces].mean(axis=1)
    head = mesh.pivots[joint_of["Neck"]]
    top = np.ptp(mesh.vertices[:, 1]) * 0.06
    hair = (face_joint == joint_of["Neck"]) & (
        (centre[:, 1] > head[1] + 2.2 * top) | ((centre[:, 1] > head[1] + top) & (centre[:, 2] < head[2] - 30))
    )
    colours[hair] = rng.uniform(0.05, 0.3) * np.array([1.0, 0.8, 0.6])
    return colours


def settings_digest(settings: dict) -> str:
    """A 16-hex-digit SHA-256 digest of the generator settings (JSON with sorted keys), stored in
    sequence.json to tell whether a sequence folder was rendered with these settings."""
    return hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:16]


#: the largest image side the generator renders, px (as for calibrations)
MAX_SIDE = 16384


def check_settings(
    *,
    subject,
    action,
    frames,
    cameras,
    width,
    height,
    fps,
    seed,
    background_frames,
    noise_sigma,
    shot_noise,
    flicker,
    shadow_strength,
    shadow_softness,
    distortion,
    turn_deg,
) -> None:
    """ConfigError naming the ``dataset.*`` key of the first bad generator setting (before
    anything is rendered or allocated)."""
    subject_dimensions(subject)
    check_number("dataset.frames", frames, 1, 100_000, integer=True)
    check_number("dataset.width", width, 32, MAX_SIDE, integer=True)
    check_number("dataset.height", height, 32, MAX_SIDE, integer=True)
    check_number("dataset.fps", fps, 0, 10_000, low_open=True)
    check_number("dataset.seed", seed, 0, 2**32 - 1, integer=True)
    check_number("dataset.background_frames", background_frames, 2, 10_000, integer=True)
    check_number("dataset.turn_deg", turn_deg, -360, 360)
    for name, value, high in (
        ("noise_sigma", noise_sigma, 50),
        ("shot_noise", shot_noise, 5),
        ("flicker", flicker, 0.3),
        ("shadow_strength", shadow_strength, 1),
        ("shadow_softness", shadow_softness, 0.5),
        ("distortion", distortion, 10),
    ):
        check_number(f"dataset.{name}", value, 0, high)
    known = [name for name, _, _ in CAMERA_RING]
    if isinstance(cameras, str) or not all(isinstance(c, str) for c in cameras) or not cameras:
        raise ConfigError(f"dataset cameras must be a list of names from {', '.join(known)}, got {cameras!r}")
    unknown = [c for c in cameras if c not in known]
    if unknown:
        raise ConfigError(f"dataset cameras: unknown camera {', '.join(unknown)}; known: {', '.join(known)}")
    if not isinstance(action, str):
        raise ConfigError(f"dataset.action must be a name, got {action!r}")


def generate(
    root,
    subject: str = "S1",
    action: str = "walking",
    frames: int = 60,
    cameras=("C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4"),
    width: int = 640,
    height: int = 480,
    fps: float = 60.0,
    seed: int = 0,
    background_frames: int = 10,
    noise_sigma: float = 2.0,
    shot_noise: float = 0.02,
    flicker: float = 0.02,
    shadow_strength: float = 0.4,
    shadow_softness: float = 0.15,
    distortion: float = 1.0,
    turn_deg: float = 0.0,
    realism: Realism = EXACT,
    progress: bool = True,
) -> Path:
    """Render one sequence into ``root`` (replacing what is there) and return its path.

    ``sequence.json`` is written last, so a folder without it is an interrupted generation; a
    failure to write (a :class:`~mmocap.io.WriteError` naming the file or ``root``: a full
    disk, a read-only folder) removes the half-rendered folder.

    Lighting and sensor (see ``conf/dataset/synthetic.yaml``): ``noise_sigma`` read noise
    (grey levels), ``shot_noise`` shot-noise variance per grey level, ``flicker`` standard
    deviation of the light's gain from frame to frame (background frames included; every
    camera sees the same light), ``shadow_strength`` fraction of the light the person's floor
    shadow removes at its core, ``shadow_softness`` angular radius of the area light (rad).
    ``turn_deg`` turns the motion about the vertical axis through the origin
    (:func:`~mmocap.data.motion.generate_motion`): 180 faces the person the other way.
    ``realism``: the departures from the tracker's assumptions (:mod:`mmocap.data.realism`);
    the calibration written is then the calibrated cameras', the images are rendered with
    the true ones. With ``realism.detector`` set, a simulated detector's keypoints are
    written too, one OpenPose JSON file per frame and camera
    (:func:`mmocap.data.keypoints.openpose_path`), drawn from a stream of their own so that
    everything else is as without them.
    """
    settings = dict(
        subject=subject,
        action=action,
        frames=frames,
        cameras=cameras,
        width=width,
        height=height,
        fps=fps,
        seed=seed,
        background_frames=background_frames,
        noise_sigma=noise_sigma,
        shot_noise=shot_noise,
        flicker=flicker,
        shadow_strength=shadow_strength,
        shadow_softness=shadow_softness,
        distortion=distortion,
        turn_deg=turn_deg,
    )
    check_settings(**settings)
    settings = {**settings, "cameras": list(cameras), "realism": realism.as_dict()}
    drawn = realism_draws.draw_rng(seed, subject, action)
    dims = realism_draws.true_dimensions(subject_dimensions(subject), realism, drawn)
    rng = np.random.default_rng([seed, sum(map(ord, subject)), sum(map(ord, action))])
    mesh = fit_subject(load_makehuman(), dims)
    frames_of = rest_frames(mesh)
    cams = camera_rig(list(cameras), width, height, rng, distortion=distortion)
    calibrations = [realism_draws.calibrated(cam, realism, drawn) for cam in cams]
    offsets_frames = realism_draws.time_offsets(len(cams), realism, drawn)
    floor = float(-mesh.vertices[:, 1].min())
    poses = generate_motion(action, frames, fps, floor, seed=int(rng.integers(2**31)), turn_deg=turn_deg)
    colours = face_colours(mesh, rng)
    markers_idx = marker_vertices(mesh)
    marker_offsets = realism_draws.marker_offsets(mesh, markers_idx, realism, drawn)
    background_gains = 1 + flicker * rng.standard_normal(background_frames)
    frame_gains = 1 + flicker * rng.standard_normal(frames)
    sensor = dict(noise_sigma=noise_sigma, shot_noise=shot_noise)

    root = Path(root)
    try:
        with writing(root):
            if root.exists():
                shutil.rmtree(root)
            for sub in ("calibration", "background", "images", "silhouettes"):
                (root / sub).mkdir(parents=True)
            backgrounds = _write_backgrounds(root, cams, calibrations, rng, background_gains, sensor)
            colours = realism_draws.camouflaged(colours, list(backgrounds.values()), realism.camouflage)

            def skinning(offset_frames: float) -> np.ndarray:
                """(frames, 16, 4, 4) skinning transforms at the frame times + the offset."""
                posed = realism_draws.poses_at(poses, offset_frames)
                return skinning_transforms(global_transforms(posed, mesh.pivots, frames_of), mesh.pivots)

            S = skinning(0.0)
            markers = realism_draws.posed_markers(mesh, markers_idx, marker_offsets, S)
            S_of = [S if offset == 0 else skinning(offset) for offset in offsets_frames]
            light = dict(gains=frame_gains, shadow_strength=shadow_strength, shadow_softness=shadow_softness)
            frame_numbers = tqdm(range(frames), desc=f"render {subject} {action}", unit="frame", disable=not progress)
            areas = _write_frames(root, mesh, colours, zip(cams, S_of), backgrounds, rng, frame_numbers, light, sensor)
            keypoints_drawn = _write_keypoints(root, mesh, zip(cams, S_of, areas), realism, (seed, subject, action))
            write_markers(root / "markers_mm.csv", markers, MARKER_NAMES)
            np.save(root / "poses.npy", poses)
            cameras_drawn = {
                cam.name: {
                    **errors,
                    "time_offset_frames": float(offset),
                    "reprojection_px": realism_draws.reprojection_px(cam, seen, markers[0]),
                }
                for cam, (seen, errors), offset in zip(cams, calibrations, offsets_frames)
            }
            meta = _sequence_meta(settings, dims, [c.name for c in cams], poses, cameras_drawn, keypoints_drawn)
            # Written last: a folder without it is an interrupted generation and is redone.
            write_text_atomic(root / "sequence.json", json.dumps(meta, indent=1))
    except BaseException:
        shutil.rmtree(root, ignore_errors=True)  # no half-rendered sequence is left behind
        raise
    return root


def _write_backgrounds(root: Path, cams, calibrations, rng: np.random.Generator, gains, sensor: dict) -> dict:
    """Write each camera's calibration (the calibrated camera of ``calibrations``) and its
    empty-scene frames (one per gain in ``gains``), and make its image and silhouette folders;
    returns each camera's noiseless background ((H, W, 3) uint8 BGR), by name."""
    backgrounds = {}
    for cam, (seen, _) in zip(cams, calibrations):
        seen.save(root / "calibration" / f"{cam.name}.json")
        backgrounds[cam.name] = render.make_background(cam, rng)
        folder = root / "background" / cam.name
        folder.mkdir()
        noisy = render.noisy_background_frames(backgrounds[cam.name], cam, rng, len(gains), gains=gains, **sensor)
        for k, img in enumerate(noisy):
            write_image(folder / f"{k:04d}.png", img)
        (root / "images" / cam.name).mkdir()
        (root / "silhouettes" / cam.name).mkdir()
    return backgrounds


def _write_frames(
    root: Path, mesh, colours, views, backgrounds: dict, rng, frame_numbers, light: dict, sensor: dict
) -> np.ndarray:
    """Render and write each frame's image and true silhouette in every view; returns the
    silhouettes' areas (cameras, frames), px.

    Args:
        root: the sequence folder, its ``images/`` and ``silhouettes/`` camera folders made.
        mesh: the subject's skinned mesh (mm).
        colours: (faces, 3) RGB colour of each face, in [0, 1] (:func:`face_colours`).
        views: (camera, its (frames, 16, 4, 4) skinning transforms) per camera; cameras at the
            same time offset share the transforms and so the posed mesh.
        backgrounds: each camera's noiseless background ((H, W, 3) uint8 BGR), by name.
        rng: the sequence's generator (the sensor noise).
        frame_numbers: the frames to render, in order (a progress bar may wrap them).
        light: ``gains`` (one per frame), ``shadow_strength`` and ``shadow_softness``.
        sensor: ``noise_sigma`` and ``shot_noise`` (:func:`mmocap.data.render.render_view`).
    """
    views = list(views)
    areas = []
    for f in frame_numbers:
        posed = {}  # cameras at the same time offset share the posed mesh
        for cam, S_cam in views:
            if id(S_cam) not in posed:
                posed[id(S_cam)] = mesh.posed(S_cam[f])
            vertices = posed[id(S_cam)]
            shadow = render.floor_shadow(
                cam, vertices, mesh.faces, render.LIGHT_DIR, light["shadow_strength"], light["shadow_softness"]
            )
            image, silhouette = render.render_view(
                cam,
                vertices,
                mesh.faces,
                colours,
                backgrounds[cam.name],
                rng,
                gain=light["gains"][f],
                shadow=shadow,
                **sensor,
            )
            write_image(root / "images" / cam.name / f"{f:06d}.png", image)
            write_image(root / "silhouettes" / cam.name / f"{f:06d}.png", silhouette.astype(np.uint8) * 255)
            areas.append(int(np.count_nonzero(silhouette)))
    return np.array(areas, np.float64).reshape(-1, len(views)).T


def _write_keypoints(root: Path, mesh, views, realism: Realism, sequence: tuple[int, str, str]) -> dict | None:
    """Write the simulated detector's keypoint files (``pose/<camera>_json/``, OpenPose's
    layout) for every frame and camera, and return what was drawn (None, and nothing
    written, without a detector).

    Args:
        root: the sequence folder.
        mesh: the true (rendered) body (mm).
        views: (true camera, its (frames, 16, 4, 4) skinning transforms, its silhouettes'
            areas (frames,) px) per camera.
        realism: the detector's settings.
        sequence: the sequence's seed, subject and action, which seed the detections' own
            generator (:func:`mmocap.data.realism.keypoint_rng`).

    Returns:
        The skeleton, each mapped joint's drawn definition offset (mm, rest frame) and the
        counts of detections (mapped joints x frames x cameras) and of missed,
        outside-image and swapped joints over all of them.
    """
    if realism.detector is None:
        return None
    rng = realism_draws.keypoint_rng(*sequence)
    joints = realism_draws.detector_joints(realism.detector, realism.keypoint_offset_sd_mm, rng)
    counts = {"detections": 0, "missed": 0, "outside": 0, "swapped": 0}
    for cam, S_cam, areas in views:
        world = realism_draws.posed_joints(mesh, joints, S_cam)
        found, drawn = realism_draws.detections(cam, world, np.sqrt(areas), joints, realism, rng)
        counts["detections"] += found.shape[0] * len(joints.names)
        for key, value in drawn.items():
            counts[key] += value
        for f, person in enumerate(found):
            write_openpose_json(openpose_path(root, cam.name, f), [person] if np.any(person[:, 2] > 0) else [])
    offsets = {name: offset.tolist() for name, offset in zip(joints.names, joints.offsets_mm)}
    return {"detector": joints.skeleton, "offsets_mm": offsets, **counts}


def _sequence_meta(
    settings: dict, dims, cameras: list[str], poses: np.ndarray, cameras_drawn: dict, keypoints_drawn: dict | None
) -> dict:
    """The contents of ``sequence.json``: what was rendered with which ``settings``, the
    true body ``dims``, the first pose of ``poses`` ((frames, 51), mm and rad) and what the
    realism drew per camera (``cameras_drawn``) and for the simulated detector
    (``keypoints_drawn``, None without one)."""
    return {
        "format": FORMAT,
        "subject": settings["subject"],
        "action": settings["action"],
        "fps": settings["fps"],
        "frames": settings["frames"],
        "cameras": cameras,
        "marker_names": list(MARKER_NAMES),
        "dimensions": {"height_mm": dims.height_mm, "girth": dims.girth},
        "x0": poses[0].tolist(),
        "units": {"length": "mm", "angle": "rad"},
        "generator": {**settings, "digest": settings_digest(settings)},
        "realism": {"cameras": cameras_drawn, **({} if keypoints_drawn is None else {"keypoints": keypoints_drawn})},
    }


class SyntheticDataset:
    """Hydra component: a synthetic sequence, generated on first use and then reused.

    The folder is ``<root>/<subject>_<action>`` (``_<realism name>`` appended unless
    ``exact``); it is regenerated when the generation
    settings (``realism`` included: the ``realism`` config node, see
    :class:`mmocap.data.realism.Realism`) differ from those recorded in its ``sequence.json``.
    """

    def __init__(
        self,
        root: str = "outputs/data",
        subject: str = "S1",
        action: str = "walking",
        frames: int = 60,
        cameras=("C1", "C2", "C3", "BW1"),
        all_cameras=("C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4"),
        width: int = 640,
        height: int = 480,
        fps: float = 60.0,
        seed: int = 0,
        background_frames: int = 10,
        noise_sigma: float = 2.0,
        shot_noise: float = 0.02,
        flicker: float = 0.02,
        shadow_strength: float = 0.4,
        shadow_softness: float = 0.15,
        distortion: float = 1.0,
        turn_deg: float = 0.0,
        realism=None,
    ):
        self.realism = Realism.from_config(realism)
        check_settings(
            subject=subject,
            action=action,
            frames=frames,
            cameras=list(all_cameras),
            width=width,
            height=height,
            fps=fps,
            seed=seed,
            background_frames=background_frames,
            noise_sigma=noise_sigma,
            shot_noise=shot_noise,
            flicker=flicker,
            shadow_strength=shadow_strength,
            shadow_softness=shadow_softness,
            distortion=distortion,
            turn_deg=turn_deg,
        )
        missing = [c for c in cameras if c not in all_cameras]
        if missing:
            raise ConfigError(
                f"dataset.cameras: {', '.join(map(str, missing))} not in dataset.all_cameras "
                f"({', '.join(all_cameras)}); add them there"
            )
        level = "" if self.realism.name == "exact" else f"_{self.realism.name}"
        turned = f"_turn{float(turn_deg):g}" if turn_deg else ""
        self.path = Path(root) / f"{subject}_{action}{turned}{level}"
        self.cameras = list(cameras)
        self.settings: dict[str, Any] = dict(
            subject=subject,
            action=action,
            frames=frames,
            cameras=list(all_cameras),
            width=width,
            height=height,
            fps=fps,
            seed=seed,
            background_frames=background_frames,
            noise_sigma=noise_sigma,
            shot_noise=shot_noise,
            flicker=flicker,
            shadow_strength=shadow_strength,
            shadow_softness=shadow_softness,
            distortion=distortion,
            turn_deg=turn_deg,
        )

    def open(self, progress: bool = True) -> Sequence:
        """The sequence, rendered first unless its folder holds one made with these settings
        (``progress``: show a progress bar while rendering)."""
        meta_path = self.path / "sequence.json"
        current = None
        if meta_path.is_file():
            try:
                current = read_json_object(meta_path)["generator"]["digest"]
            except (DataError, TypeError, KeyError) as exc:  # this class's own output, damaged: render again
                log.warning("%s is unreadable (%s); rendering the sequence again", meta_path, exc)
        if current != settings_digest({**self.settings, "realism": self.realism.as_dict()}):
            generate(self.path, progress=progress, realism=self.realism, **self.settings)
        return Sequence.open(self.path, self.cameras)
