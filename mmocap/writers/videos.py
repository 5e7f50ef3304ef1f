"""Pictures of a tracking run that people look at: one video per camera and the 3-D skeleton.

With ``video=true`` a run writes, besides its other outputs:

- ``videos/<camera>.mp4``: every tracked frame of the camera, undistorted, with the pixels
  of the foreground only, of the model only and of both in three colours (a legend in the
  bottom corner), the skeleton and the true markers, and the camera, frame, fitness and
  marker error written on it (:func:`mmocap.writers.overlays.comparison_overlay`);
- ``skeleton.png``: stick figures of the tracked joints at evenly spaced frames;
- ``skeleton.mp4``: the stick figure over the whole run.

Videos are H.264 MP4 at the sequence's frame rate (:func:`mmocap.video.write_video`),
written atomically and read back to check their frame count.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from mmocap.body.skeleton import PARENT_INDEX
from mmocap.run_folder import SKELETON_FILES, VIDEOS
from mmocap.stages.accuracy import marker_error
from mmocap.video import write_video
from mmocap.writers.overlays import comparison_overlay
from mmocap.writers.skeleton import plot_skeleton_strip, write_skeleton_animation


def camera_frames(sequence, foreground, evaluator, body, results, truth, camera_index: int):
    """The comparison images ((H, W, 3) BGR uint8) of one camera, one per result, in order.

    ``results`` are the run's FrameResults; ``truth`` (frames, M, 3) mm, NaN where missing.
    The evaluator is set up on each frame's masks to render the model's silhouette."""
    camera = sequence.cameras[camera_index]
    ideal = foreground.cameras[camera_index]
    mx, my = camera.undistort_maps()
    for result in results:
        masks = foreground.masks(result.frame)
        evaluator.setup(body, foreground.cameras, masks)
        image = cv2.remap(sequence.images(result.frame)[camera_index], mx, my, cv2.INTER_LINEAR)
        joints = body.joint_positions(result.pose[None])[0]
        yield comparison_overlay(
            image,
            ideal,
            masks[camera_index],
            evaluator.render(result.pose, camera_index),
            joints,
            truth[result.frame],
            frame_caption(camera.name, result, body, truth),
        )


def frame_caption(camera_name: str, result, body, truth) -> tuple[str, str, str]:
    """The lines written on a camera's video frame: the camera and frame, the frame's fitness,
    and its marker error (mm, as in ``frames.csv``) or "no ground truth" where ``truth``
    ((frames, M, 3) mm) has no marker of the frame."""
    error = marker_error(body.markers(result.pose[None]), truth[result.frame][None])[0]
    return (
        f"{camera_name}  frame {result.frame}",
        f"fitness {result.fitness:.4f}",
        "no ground truth" if np.isnan(error) else f"marker error {error:.1f} mm",
    )


def write_run_videos(
    folder: Path, sequence, foreground, evaluator, body, results, truth, progress: bool = False
) -> list[Path]:
    """Write the videos and skeleton pictures of the module docstring into the run folder
    ``folder``; returns their paths. ``results`` are the run's FrameResults (poses in mm, rad)."""
    folder = Path(folder)
    written = []
    for c, camera in enumerate(sequence.cameras):
        frames = camera_frames(sequence, foreground, evaluator, body, results, truth, c)
        written.append(
            write_video(
                folder / VIDEOS / f"{camera.name}.mp4", frames, sequence.fps, count=len(results), progress=progress
            )
        )
    joints = body.joint_positions(np.stack([r.pose for r in results]))
    title = f"{sequence.meta.get('action')}: tracked joints"
    plot_skeleton_strip(joints, PARENT_INDEX, folder / SKELETON_FILES[0], title)
    written.append(folder / SKELETON_FILES[0])
    written.append(
        write_skeleton_animation(
            joints, PARENT_INDEX, folder / SKELETON_FILES[1], sequence.fps, title=title, progress=progress
        )
    )
    return written


def run_video_files(folder: Path) -> list[Path]:
    """The files :func:`write_run_videos` may have written into the run folder ``folder``,
    with the temporaries a stopped run leaves beside them (``.<name>.<random>.tmp`` and the
    encoder's ``.<name>.<random>.mp4``)."""
    folder = Path(folder)
    videos = folder / VIDEOS
    return [
        *videos.glob("*.mp4"),
        *videos.glob(".*.tmp"),  # "*.mp4" matches the hidden temporaries too
        *(folder / name for name in SKELETON_FILES),
        *(temporary for name in SKELETON_FILES for temporary in folder.glob(f".{name}.*")),
    ]
