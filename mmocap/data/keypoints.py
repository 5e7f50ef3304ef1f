"""2-D keypoint files: OpenPose-style JSON per camera and frame (Pose2Sim's layout).

Pose2Sim, OpenPose, RTMPose/rtmlib, AlphaPose and others write one JSON file per frame and
camera, ``pose/<camera>_json/<camera>_<frame:06d>.json``, holding ``people``, each with its
``pose_keypoints_2d``: ``x, y, confidence`` for every joint of the detector's skeleton
(:mod:`mmocap.data.skeletons`), in pixels of the raw (distorted) image.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from mmocap.camera import Camera
from mmocap.data.skeletons import SKELETONS, skeleton_joints
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.io import read_csv_table, read_json_object, write_json_atomic

#: the folder of a recording (or synthetic sequence) that holds the keypoint files
POSE_FOLDER = "pose"


def openpose_path(root: Path, camera: str, frame: int) -> Path:
    """Where Pose2Sim writes camera ``camera``'s keypoints of ``frame`` under ``root``."""
    return Path(root) / POSE_FOLDER / f"{camera}_json" / f"{camera}_{frame:06d}.json"


def write_openpose_json(path: Path, people: list[np.ndarray]) -> None:
    """Write one frame's detections as an OpenPose JSON file.

    Args:
        path: the file to write (its folder is made).
        people: one (J, 3) array per person: x, y in px and the confidence in [0, 1]; a
            joint not found is written as 0, 0, 0, as OpenPose does.
    """
    entries = []
    for person in people:
        person = np.asarray(person, np.float64)
        values = np.where(np.isfinite(person), person, 0.0)
        values[person[:, 2] <= 0] = 0.0
        entries.append({"person_id": [-1], "pose_keypoints_2d": [round(float(v), 3) for v in values.ravel()]})
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, {"version": 1.3, "people": entries})


#: a keypoint table in a recording's (or sequence's) root: one row per frame, camera and joint
KEYPOINTS_CSV = "keypoints.csv"
#: the columns of :data:`KEYPOINTS_CSV`
CSV_COLUMNS = ("frame", "camera", "joint", "u", "v", "confidence")
#: the config key that names the skeleton, for messages
SKELETON_KEY = "keypoints.skeleton"
#: the skeleton name that reads the skeleton off the files
AUTO = "auto"
#: the frame number at the end of an OpenPose file's name: ``<anything>_<digits>.json``
FRAME_NUMBER = re.compile(r"_(\d+)\.json$")
#: a missing joint as :func:`write_openpose_json` and OpenPose write it
UNSEEN = (0.0, 0.0, 0.0)


def skeleton_named(name: str) -> tuple[str, ...]:
    """The joints of the skeleton ``name`` (a key of :data:`mmocap.data.skeletons.SKELETONS`);
    a ConfigError naming :data:`SKELETON_KEY` and the known names otherwise."""
    if name not in SKELETONS:
        raise ConfigError(f"{SKELETON_KEY}: unknown keypoint skeleton {name!r}; known: {AUTO}, {', '.join(SKELETONS)}")
    return skeleton_joints(name)


def skeleton_of_count(count: int, where: str) -> str:
    """The skeleton whose joints x 3 values (x, y, confidence) are ``count``; a DataError
    naming ``where`` (the file) when none is."""
    for name, joints in SKELETONS.items():
        if 3 * len(joints) == count:
            return name
    sizes = ", ".join(f"{name} {3 * len(joints)}" for name, joints in SKELETONS.items())
    raise DataError(
        f"{where} holds {count} values per person, 3 x the joints of no known skeleton ({sizes}); "
        f"write one of them, or give {SKELETON_KEY}"
    )


def skeleton_of_names(names, where: str) -> str:
    """The smallest skeleton holding every joint name in ``names``; a DataError naming
    ``where`` when none does."""
    names = set(names)
    fitting = [name for name, joints in SKELETONS.items() if names <= set(joints)]
    if not fitting:
        raise DataError(
            f"{where}: the joints {', '.join(sorted(names)[:8])} are not those of one known skeleton "
            f"({', '.join(SKELETONS)}); name the joints as docs/keypoints.md lists them"
        )
    return min(fitting, key=lambda name: len(SKELETONS[name]))


def frame_ranges(frames) -> str:
    """Sorted frame numbers as ranges: ``[3, 4, 5, 9]`` -> ``"3-5, 9"``."""
    frames = sorted(frames)
    parts, start = [], None
    for k, frame in enumerate(frames):
        if start is None:
            start = frame
        if k + 1 == len(frames) or frames[k + 1] != frame + 1:
            parts.append(str(frame) if frame == start else f"{start}-{frame}")
            start = None
    return ", ".join(parts)


def checked_joints(values: np.ndarray, labels, where: str) -> np.ndarray:
    """Joints checked: ``values`` (N, 3) x, y (px) and confidence, ``labels`` (N,) what to
    call each row in a message (``joint LHip``); a DataError naming ``where`` and the row for
    a confidence outside [0, 1] or a confident joint whose x or y is NaN or infinite.
    Returns (N, 3) float64, unseen joints (confidence 0) as :data:`UNSEEN`."""
    confidence = values[:, 2]
    outside = ~((confidence >= 0) & (confidence <= 1))
    if outside.any():
        j = int(np.argmax(outside))
        raise DataError(
            f"{where}: {labels[j]} has confidence {confidence[j]:g}, outside [0, 1]; "
            "scale the detector's scores to [0, 1]"
        )
    broken = (confidence > 0) & ~np.isfinite(values[:, :2]).all(axis=1)
    if broken.any():
        j = int(np.argmax(broken))
        raise DataError(
            f"{where}: {labels[j]} has coordinates ({values[j, 0]:g}, {values[j, 1]:g}) with confidence "
            f"{confidence[j]:g}; write a joint not found as 0, 0, 0 (confidence 0)"
        )
    out = values.astype(np.float64, copy=True)
    out[confidence == 0] = UNSEEN
    return out


def json_folders(folder: Path) -> dict[str, Path]:
    """Camera name -> its ``<camera>_json/`` folder in ``folder`` (a ``pose/`` folder; empty
    if there is none). Pose2Sim's other outputs there (``_pose.mp4``, ``_img/``) are not."""
    if not folder.is_dir():
        return {}
    return {p.name[: -len("_json")]: p for p in folder.iterdir() if p.is_dir() and p.name.endswith("_json")}


def read_people(path: Path) -> list[np.ndarray]:
    """The ``pose_keypoints_2d`` of every person in the OpenPose JSON file ``path``, each a
    flat float64 array; a DataError naming the file when it is not one (a file cut short does
    not parse: refused too)."""
    data = read_json_object(path, wanted="an OpenPose JSON object", fix="write it again with the detector")
    people = data.get("people")
    if not isinstance(people, list):
        raise DataError(f"{path} holds no 'people' list: is it an OpenPose JSON file? write it again with the detector")
    out = []
    for k, person in enumerate(people):
        values = person.get("pose_keypoints_2d") if isinstance(person, dict) else None
        try:
            out.append(np.asarray(values, dtype=np.float64).reshape(-1))
        except (TypeError, ValueError):
            values = None
        if not isinstance(values, list):
            raise DataError(
                f"{path}, person {k + 1}: 'pose_keypoints_2d' is not a list of numbers; "
                "write it again with the detector"
            )
    return out


class KeypointFiles:
    """The 2-D keypoints of a recording or sequence, read whole at opening and checked, or refused.

    Two formats (``docs/keypoints.md``, "Keypoint files"): OpenPose JSON files in Pose2Sim's
    layout (:func:`openpose_path`; the frame number is the file name's trailing ``_<digits>``),
    or :data:`KEYPOINTS_CSV` (the columns :data:`CSV_COLUMNS`). Frame ``k`` of the sequence is
    frame ``first_frames[c] + k`` of camera ``c``'s files, which must cover them all. A file
    holding several people gives the one with the highest summed confidence (a
    :class:`MmocapWarning` per camera lists the frames); a file holding nobody gives every
    joint confidence 0.

    A file cut short is refused: a JSON file that does not parse, a table whose last line has
    no line end (a cut number would read as another: :func:`mmocap.io.check_whole_lines`). A
    table cut at a row's end holds whole rows: the frames it lacks are refused, and the joints
    of its last frame whose rows were lost read as not found, as a row left out means.

    Args:
        root: the recording or sequence folder.
        cameras: the camera names, in the order :meth:`frame` gives them.
        n_frames: the sequence's frame count.
        skeleton: a name of :data:`mmocap.data.skeletons.SKELETONS`, or ``auto``: from the
            values per person (JSON) or the joint names (CSV).
        first_frames: per camera, the file frame of the sequence's frame 0 (None: 0 each).
        calibrated: every camera of the calibration (None: ``cameras``); files of another
            camera are refused.
        shrunk: per camera, ``(camera, shrunk camera)``: the files' pixels are the first's,
            returned as the second's (:meth:`mmocap.camera.Camera.shrunk_pixels`; None: as read).

    Raises:
        DataError: one line naming the file (and the camera, frame or joint) and the fix.
        ConfigError: an unknown ``skeleton``.
    """

    def __init__(
        self,
        root: Path,
        cameras: list[str],
        n_frames: int,
        skeleton: str = AUTO,
        first_frames: list[int] | None = None,
        calibrated: list[str] | None = None,
        shrunk: list[tuple[Camera, Camera]] | None = None,
    ):
        self.root, self.cameras, self.n_frames = Path(root), list(cameras), int(n_frames)
        if skeleton != AUTO:
            skeleton_named(skeleton)
        self.skeleton = skeleton
        self.first_frames = list(first_frames) if first_frames is not None else [0] * len(self.cameras)
        json_folder, table = self.root / POSE_FOLDER, self.root / KEYPOINTS_CSV
        if json_folders(json_folder) and table.is_file():
            raise DataError(f"{self.root} holds keypoints twice, {json_folder}/ and {table}; keep one")
        if not KeypointFiles.has(self.root):
            raise DataError(f"{self.root} holds no keypoint files (no {json_folder}/<camera>_json/, no {table})")
        self.source = table if table.is_file() else json_folder
        if self.source == table:
            data = self._read_csv(table, set(calibrated or self.cameras))
        else:
            data = self._read_json(json_folder, calibrated or self.cameras)
        for c, (camera, small) in enumerate(shrunk or []):
            seen = data[:, c, :, 2:] > 0
            data[:, c, :, :2] = np.where(seen, camera.shrunk_pixels(data[:, c, :, :2], small), 0.0)
        self._data = data

    @staticmethod
    def has(root: Path) -> bool:
        """True when ``root`` holds keypoint files: ``pose/<camera>_json/`` folders or
        :data:`KEYPOINTS_CSV`."""
        return (Path(root) / KEYPOINTS_CSV).is_file() or bool(json_folders(Path(root) / POSE_FOLDER))

    @property
    def joints(self) -> tuple[str, ...]:
        """The skeleton's joint names, in the order of :meth:`frame`'s second axis."""
        return skeleton_joints(self.skeleton)

    def frame(self, frame: int) -> np.ndarray:
        """(C, J, 3) float64 for the sequence's frame ``frame`` (0-based): per camera (in the
        order given) and joint, u, v in pixels of the raw (distorted) image and the confidence
        in [0, 1]; a joint not seen has confidence 0 (and u = v = 0)."""
        if not 0 <= frame < self.n_frames:
            raise DataError(f"frame {frame} outside the {self.n_frames} frames of the keypoints in {self.source}")
        return self._data[frame].copy()

    def ideal_frame(self, frame: int, cameras: list) -> np.ndarray:
        """:meth:`frame` with u, v in pixels of the ideal (undistorted) ``cameras``
        (:meth:`mmocap.camera.Camera.ideal_pixels`; the sequence's cameras, in its order);
        unseen joints stay 0, 0, 0."""
        out = self.frame(frame)
        for c, camera in enumerate(cameras):
            seen = out[c, :, 2] > 0
            out[c, seen, :2] = camera.ideal_pixels(out[c, seen, :2])
        return out

    # --- OpenPose JSON ------------------------------------------------------------------

    def _read_json(self, folder: Path, calibrated: list[str]) -> np.ndarray:
        """(n_frames, C, J, 3) from ``folder``'s ``<camera>_json/`` folders (class docstring)."""
        found = sorted(json_folders(folder))
        strangers = [name for name in found if name not in calibrated]
        if strangers:
            raise DataError(
                f"{folder} holds keypoints of camera(s) {', '.join(strangers)}, which the calibration lacks "
                f"(it has {', '.join(calibrated)}); rename the <camera>_json folders after its cameras, or remove them"
            )
        lacking = [name for name in self.cameras if name not in found]
        if lacking:
            raise DataError(
                f"{folder} holds no keypoints of camera(s) {', '.join(lacking)} (no {lacking[0]}_json/ folder); "
                "detect them in every camera, or leave those cameras out with dataset.cameras"
            )
        people = [self._camera_people(folder / f"{name}_json", c) for c, name in enumerate(self.cameras)]
        if self.skeleton == AUTO:
            first = next(((path, p[0]) for camera in people for path, p in camera if p), None)
            if first is None:
                raise DataError(
                    f"{folder}: no file holds a person, so {SKELETON_KEY}={AUTO} cannot tell the skeleton; "
                    f"name it ({', '.join(SKELETONS)})"
                )
            self.skeleton = skeleton_of_count(first[1].size, str(first[0]))
        joints = self.joints
        data = np.zeros((self.n_frames, len(self.cameras), len(joints), 3))
        for c, camera in enumerate(people):
            crowded = []
            for k, (path, persons) in enumerate(camera):
                if not persons:
                    continue
                checked = [self._person(values, joints, path, p) for p, values in enumerate(persons)]
                data[k, c] = max(checked, key=lambda person: person[:, 2].sum())
                if len(persons) > 1:
                    crowded.append(self.first_frames[c] + k)
            if crowded:
                warnings.warn(
                    f"camera {self.cameras[c]}: {folder / (self.cameras[c] + '_json')} holds several people in "
                    f"{len(crowded)} of {self.n_frames} frames ({frame_ranges(crowded)}): the one with the highest "
                    "summed confidence is taken",
                    MmocapWarning,
                    stacklevel=3,
                )
        return data

    def _camera_people(self, folder: Path, c: int) -> list[tuple[Path, list[np.ndarray]]]:
        """Per sequence frame, camera ``c``'s file in ``folder`` and its people."""
        by_frame: dict[int, Path] = {}
        for path in folder.iterdir():
            if path.suffix.lower() != ".json":
                continue
            match = FRAME_NUMBER.search(path.name)
            if match is None:
                raise DataError(
                    f"{path}: no frame number at the end of its name; name the files <camera>_<frame>.json "
                    "(Pose2Sim's layout)"
                )
            frame = int(match.group(1))
            if frame in by_frame:
                raise DataError(f"{path} and {by_frame[frame]} both hold frame {frame}; keep one")
            by_frame[frame] = path
        first = self.first_frames[c]
        wanted = range(first, first + self.n_frames)
        absent = [frame for frame in wanted if frame not in by_frame]
        if absent:
            raise DataError(
                f"camera {self.cameras[c]}: {folder} lacks frame {absent[0]} "
                f"({len(absent)} of the frames {first}-{first + self.n_frames - 1} the sequence needs are missing); "
                f"write a file for every frame (one with no people where nobody was found), e.g. "
                f"{openpose_path(self.root, self.cameras[c], absent[0]).name}"
            )
        return [(by_frame[frame], read_people(by_frame[frame])) for frame in wanted]

    @staticmethod
    def _person(values: np.ndarray, joints: tuple[str, ...], path: Path, p: int) -> np.ndarray:
        where = f"{path}, person {p + 1}"
        if values.size != 3 * len(joints):
            skeleton = next(name for name, js in SKELETONS.items() if js == joints)
            raise DataError(
                f"{where}: {values.size} values, but {skeleton} has {len(joints)} joints x 3 (x, y, confidence) = "
                f"{3 * len(joints)}; set {SKELETON_KEY} to the detector's skeleton"
            )
        return checked_joints(values.reshape(-1, 3), [f"joint {name}" for name in joints], where)

    # --- CSV ----------------------------------------------------------------------------

    def _read_csv(self, path: Path, calibrated: set[str]) -> np.ndarray:
        """(n_frames, C, J, 3) from the long table ``path`` (class docstring)."""
        table = read_csv_table(path, CSV_COLUMNS, "one row per joint", dtype={"camera": str, "joint": str})
        if table.empty:
            raise DataError(f"{path} holds no rows, only its header")
        frames = pd.to_numeric(table["frame"], errors="coerce")
        bad = ~np.isfinite(frames) | (frames != np.round(frames))
        if bad.any():
            raise DataError(f"{path}: column 'frame' must hold integer frame numbers; line {bad.idxmax() + 2}")
        table["camera"] = table["camera"].fillna("")
        strangers = sorted(set(table["camera"]) - calibrated)
        if strangers:
            raise DataError(
                f"{path} holds keypoints of camera(s) {', '.join(map(str, strangers))}, which the calibration lacks "
                f"(it has {', '.join(sorted(calibrated))}); name the cameras as the calibration does"
            )
        lacking = [name for name in self.cameras if name not in set(table["camera"])]
        if lacking:
            raise DataError(
                f"{path} holds no keypoints of camera(s) {', '.join(lacking)}; detect them in every camera, "
                "or leave those cameras out with dataset.cameras"
            )
        if self.skeleton == AUTO:
            self.skeleton = skeleton_of_names(table["joint"].dropna().unique(), str(path))
        joints = self.joints
        joint = table["joint"].map({name: j for j, name in enumerate(joints)})
        if joint.isna().any():
            line = int(joint.isna().to_numpy().argmax()) + 2
            raise DataError(
                f"{path}: line {line}: joint {table['joint'].iloc[line - 2]!r} is not one of {self.skeleton}'s "
                f"({', '.join(joints)}); set {SKELETON_KEY} to the detector's skeleton"
            )
        values = np.stack([pd.to_numeric(table[c], errors="coerce").to_numpy(np.float64) for c in CSV_COLUMNS[3:]], 1)
        data = np.zeros((self.n_frames, len(self.cameras), len(joints), 3))
        for c, name in enumerate(self.cameras):
            lines = np.flatnonzero((table["camera"] == name).to_numpy())
            k = frames.to_numpy()[lines].astype(np.int64) - self.first_frames[c]
            lines, k = lines[(k >= 0) & (k < self.n_frames)], k[(k >= 0) & (k < self.n_frames)]
            gaps = np.setdiff1d(np.arange(self.n_frames), k)
            if gaps.size:
                raise DataError(
                    f"camera {name}: {path} lacks frame {gaps[0] + self.first_frames[c]} "
                    f"({gaps.size} of the sequence's {self.n_frames} frames are missing); give every frame at "
                    "least one row (confidence 0 where nobody was found)"
                )
            j = joint.to_numpy()[lines].astype(np.int64)
            _, first, counts = np.unique(k * len(joints) + j, return_index=True, return_counts=True)
            if (counts > 1).any():
                line = lines[first[np.argmax(counts > 1)]] + 2
                raise DataError(f"{path}: line {line}: frame, camera and joint appear again below; give each one row")
            labels = [f"line {line + 2}, joint {joints[i]}" for line, i in zip(lines, j)]
            data[k, c, j] = checked_joints(values[lines], labels, str(path))
        return data
