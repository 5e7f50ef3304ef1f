"""Multi-camera calibrations in the formats that calibration tools write.

:func:`read_calibration` reads one file holding every camera (or a folder of per-camera
files) and returns a :class:`Calibration`: mmocap :class:`~mmocap.camera.Camera` objects,
translations in mm, each built and checked by :func:`~mmocap.camera.checked_camera`.
The accepted formats are listed in :data:`CALIBRATION_FORMATS`:

- **OpenCV FileStorage** YAML (``.yml``, ``.yaml``: OpenCV 4's ``%YAML:1.0`` and 5's
  ``%YAML 1.2``), XML (``.xml``) or JSON (``.json``), read with ``cv2.FileStorage`` (PyYAML
  reads neither header). Three layouts:

  - a top-level sequence ``names`` listing the cameras, each camera's values either in a
    map named after it or in top-level keys suffixed with its name (EasyMocap's
    ``K_<name>``, ``dist_<name>``, ``R_<name>``, ...);
  - one map per camera, named after it (top-level maps holding none of the keys below,
    say ``metadata``, are skipped);
  - one camera per file, its keys at the top level (the camera is named after the file).

  The keys, any one spelling of each (:data:`KEYS`): the (3, 3) camera matrix ``K``;
  the lens distortion ``dist``: 4, 5, 8, 12 or 14 coefficients in OpenCV's order, of which
  mmocap keeps ``k1 k2 p1 p2 k3`` (4 give ``k3 = 0``) and refuses nonzero higher-order ones;
  the world-to-camera rotation ``R``, a (3, 3) matrix or a Rodrigues vector of 3;
  the world-to-camera translation ``t`` (3); the image size as ``image_width`` and
  ``image_height`` or ``size`` ``[width, height]`` in pixels; optionally ``colour`` (true
  or 1 for a colour sensor, the default) and ``fisheye`` (refused when true: mmocap's lens
  model is OpenCV's pin-hole one). A top-level string ``units`` (``mm`` or ``m``) states the
  translations' units.
- **anipose / Pose2Sim TOML** (``.toml``, read with ``tomllib``): one table per camera
  (``[cam_0]``, ``[cam_1]``, ... or any name) with ``name`` (defaults to the table's
  name), ``size`` ``[width, height]``, ``matrix`` (3, 3), ``distortions`` (4 or 5),
  ``rotation`` (Rodrigues, world to camera) and ``translation`` (world to camera); the
  tables ``metadata``, ``capture_volume``, ``charuco`` and ``checkerboard`` are skipped.
- **mmocap's calibration JSON**: a folder of ``<camera>.json`` files (or one of them),
  read by :meth:`~mmocap.camera.Camera.load`; translations in mm.
- **EasyMocap**: a folder holding ``intri.yml`` and ``extri.yml`` (the ``names`` layout
  split over two files).
- **Qualisys QTM** ``.qca.txt`` (XML, read with ``xml.etree``): one ``<camera>`` per camera
  under ``<cameras>``, named by its ``serial``; cameras with ``active="0"`` are left out
  (logged); the others are all read, marker cameras too (a recording uses those with a
  video). The video image is the sensor window ``<fov_video left top right bottom>`` in
  sensor pixels: ``(right - left + 1) x (bottom - top + 1)`` pixels (a video binned to fewer
  pixels, QTM's 540p of a 1080p window, is told by its size when a recording is opened).
  ``<intrinsic>`` gives ``focalLengthU``, ``focalLengthV``, ``centerPointU``,
  ``centerPointV`` in 1/64 sensor pixels (:data:`QTM_SUBPIXELS`; the centre is then taken
  relative to the window's ``left``, ``top``), ``skew`` (refused unless 0) and the
  dimensionless OpenCV coefficients ``radialDistortion1-3`` (k1 k2 k3) and
  ``tangentalDistortion1-2`` (p1 p2). ``<transform>`` gives the camera centre ``x y z`` in
  mm and the camera-to-world rotation listed column by column: ``r11 r12 r13`` is the
  camera's x axis in the world, ``r31 r32 r33`` its z axis, along which QTM's camera looks
  backwards (y up the image); mmocap's camera is turned half a turn about its x axis
  (:data:`QTM_TO_OPENCV`), so that
  ``R = QTM_TO_OPENCV @ [[r11 r12 r13] [r21 r22 r23] [r31 r32 r33]]`` and
  ``t = -R @ (x, y, z)``. A camera with ``viewrotation`` other than 0 is read as its sensor
  sees it (a warning says so): its videos must not be turned.
- **Vicon** ``.xcp`` (XML, as Nexus and Tracker write it): one ``<Camera>`` per camera under
  ``<Cameras>``, every one read, named by its ``DEVICEID`` (else ``USERID``, else ``NAME``),
  with ``SENSOR_SIZE`` (width height, pixels), ``PIXEL_ASPECT_RATIO`` (fy = fx / ratio) and
  ``SKEW`` (refused unless 0), and one ``<KeyFrames><KeyFrame>`` (several: a moving camera,
  refused) with ``FOCAL_LENGTH`` (pixels), ``PRINCIPAL_POINT`` (x y, pixels),
  ``ORIENTATION`` (the world-to-camera rotation as a quaternion x y z w, the real part
  last), ``POSITION`` (the camera centre, mm) and the distortion ``VICON_RADIAL2``
  (``<model> <centre x> <centre y> k1 k2 [k3]``, read as OpenCV's radial coefficients about
  the principal point, as Pose2Sim reads them; a centre elsewhere is warned of) or else
  ``VICON_RADIAL`` (k1 k2).
- A folder holding one file of a format that keeps every camera in one file (TOML,
  ``.qca.txt``, ``.xcp``: :data:`RIG_FILE_SUFFIXES`) and no other calibration file is read as
  that file (Pose2Sim's ``calibration/Calib.qca.txt``); its subfolders are ignored.

Units: mmocap's translations are in mm; tools write mm (anipose: the units of the board's
square size, usually mm; QTM and Vicon, whose files are read as stating mm) or metres
(Pose2Sim). ``units="auto"`` takes what the file states, else decides from the cameras'
distances from the world origin (their centres ``-R^T t``): rigs stand 1-10 m away, so a
median below :data:`METRES_BELOW` means metres and above :data:`MILLIMETRES_ABOVE` means
mm; in between is refused. Cameras standing at the origin (the reference camera of a rig
calibrated relative to one camera) are left out of the median. The decision and its
reason are logged in one line and returned.

Errors are one-line :class:`~mmocap.errors.DataError` messages naming the file, the camera
and the key as the file spells it.

A file cut short is refused, never read as a rig with fewer or different cameras: JSON and XML
files that do not parse, a YAML or TOML file whose last line has no line end (it may be cut
inside a number: :func:`mmocap.io.check_whole_lines`), and a YAML ``names`` list that names a
camera whose values are not all there. A TOML file cut between two camera tables is a whole
file with fewer cameras: the recording's check of its videos against the calibration names
the cameras it lacks.
"""

from __future__ import annotations

import logging
import math
import re
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from mmocap.camera import ROTATION_TOLERANCE, Camera, checked_camera
from mmocap.errors import DataError
from mmocap.io import check_whole_lines, read_lines_file, write_text_atomic
from mmocap.validate import check_choice, is_real

log = logging.getLogger(__name__)

#: suffix -> the format read from a file with it
CALIBRATION_FORMATS = {
    ".yml": "OpenCV FileStorage YAML",
    ".yaml": "OpenCV FileStorage YAML",
    ".xml": "OpenCV FileStorage XML",
    ".json": "OpenCV FileStorage JSON, or mmocap's calibration JSON (one camera, with t_mm)",
    ".toml": "anipose / Pose2Sim TOML",
    ".qca.txt": "Qualisys QTM calibration XML",
    ".xcp": "Vicon calibration XML",
}
#: the world axis pointing up in the formats whose world is a lab's by convention: QTM and Vicon
#: define the lab's frame with z up (the other formats' world is whatever the board's was)
UP_AXIS_OF_FORMAT = {
    CALIBRATION_FORMATS[".qca.txt"]: "+z",
    CALIBRATION_FORMATS[".xcp"]: "+z",
}
#: the suffixes of formats that keep every camera in one file: a folder holding one such file
#: (and no other calibration file) is read as that file
RIG_FILE_SUFFIXES = (".toml", ".qca.txt", ".xcp")
#: QTM's intrinsics count sensor pixels in 1/64ths
QTM_SUBPIXELS = 64
#: QTM's camera axes (x right, y up the image, looking along -z) -> OpenCV's (x right, y down, z forward)
QTM_TO_OPENCV = np.diag([1.0, -1.0, -1.0])
#: the attributes naming a Vicon camera, first found wins (Pose2Sim takes DEVICEID)
VICON_NAMES = ("DEVICEID", "USERID", "NAME")
#: pixels between the centre of a Vicon camera's distortion and its principal point beyond
#: which a warning says that mmocap centres the distortion on the principal point
VICON_CENTRE_PX = 1.0
#: the units ``read_calibration`` takes, and the factor turning each into mm
UNITS = {"mm": 1.0, "m": 1000.0}
#: median camera distance from the world origin below which ``units="auto"`` reads metres
METRES_BELOW = 50.0
#: median camera distance from the world origin above which ``units="auto"`` reads mm
MILLIMETRES_ABOVE = 300.0
#: what each value is called in messages, and the spellings accepted for it, first found wins
KEYS = {
    "K": ("camera matrix", ("K", "camera_matrix", "cameraMatrix", "Camera_Matrix", "matrix")),
    "dist": (
        "distortion",
        ("dist", "distortion_coefficients", "distCoeffs", "Distortion_Coefficients", "D", "distortions"),
    ),
    "R": ("rotation", ("R", "Rot", "rotation_matrix", "rvec", "rotation")),
    "t": ("translation", ("t", "T", "tvec", "translation")),
    "width": ("image width", ("image_width", "width", "W", "image_Width")),
    "height": ("image height", ("image_height", "height", "H", "image_Height")),
    "size": ("image size", ("size", "image_size")),
    "colour": ("colour flag", ("colour", "color")),
    "fisheye": ("fisheye flag", ("fisheye", "fisheye_model")),
}
#: OpenCV's distortion coefficients in order; mmocap keeps the first five
DISTORTION_NAMES = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4", "taux", "tauy")
#: how many distortion coefficients OpenCV's models have
DISTORTION_COUNTS = (4, 5, 8, 12, 14)
#: TOML tables that Pose2Sim and anipose write beside the cameras
TOML_SKIPPED = ("metadata", "capture_volume", "charuco", "checkerboard")
#: EasyMocap's two files of a calibration folder
EASYMOCAP_FILES = ("intri.yml", "extri.yml")
#: FileStorage keys: a letter or _ first, then letters, digits, _, - and spaces
_FILESTORAGE_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_ -]*")
#: top-level FileStorage keys of a calibration that are not cameras
_RESERVED = ("names", "units")


@dataclass(frozen=True)
class Calibration:
    """What :func:`read_calibration` read.

    Attributes:
        cameras: the cameras, translations in mm, in the file's order (or ``cameras=``'s).
        units: the units the file's translations were in, ``"mm"`` or ``"m"``.
        units_reason: how they were decided (set by the caller, stated by the file, or
            detected from the camera distances).
        source: the file or folder read.
        format: the format read (a value of :data:`CALIBRATION_FORMATS`, or EasyMocap's).
    """

    cameras: list[Camera]
    units: str
    units_reason: str
    source: Path
    format: str


@dataclass(frozen=True)
class _Parsed:
    """Cameras as read, translations in the file's units (``stated_units`` if it says);
    ``expected`` says where the format keeps its cameras, for a file that holds none."""

    cameras: list[Camera]
    stated_units: str | None
    format: str
    expected: str = ""


def read_calibration(
    path: str | Path,
    units: str = "auto",
    cameras: Sequence[str] | str | None = None,
    units_key: str = "calibration units",
) -> Calibration:
    """Read every camera of a calibration file or folder (see the module's docstring).

    Args:
        path: a file (:data:`CALIBRATION_FORMATS`), or a folder of per-camera files
            (``<camera>.json``, ``<camera>.yml``, ...) or EasyMocap's ``intri.yml`` and
            ``extri.yml``.
        units: the translations' units in the file: ``"mm"``, ``"m"`` or ``"auto"``.
        cameras: the names of the cameras to return, in that order (default: all, in the
            file's order); one name may be given as a string.
        units_key: the caller's name for ``units`` in its errors, e.g. ``dataset.units``.

    Returns:
        the :class:`Calibration`, translations in mm.

    Raises:
        ConfigError: ``units`` is none of mm, m, auto (named ``units_key``, the caller's
            name for the setting, e.g. ``dataset.units``).
        DataError: one line naming the file, the camera and the key: a missing file, an
            unparsable one, no cameras, a duplicate name, a missing or bad key, a camera of
            ``cameras`` not in the file, or units that cannot be told.
    """
    check_choice(units_key, units, (*UNITS, "auto"))
    path = Path(path)
    if path.is_dir():
        parsed = _read_folder(path)
    elif path.is_file():
        parsed = _read_file(path)
    else:
        raise DataError(f"calibration file not found: {path}")
    where = f"calibration {'folder' if path.is_dir() else 'file'} {path}"
    if not parsed.cameras:
        raise DataError(f"{where} holds no cameras ({parsed.format}: {parsed.expected})")
    names = [camera.name for camera in parsed.cameras]
    duplicated = sorted({name for name in names if names.count(name) > 1})
    if duplicated:
        raise DataError(f"camera {duplicated[0]}: {where} holds two cameras of that name; give each camera its own")
    units, reason = _decide_units(where, parsed, units, units_key)
    scale = UNITS[units]
    found = [replace(camera, t=camera.t * scale, _maps={}) if scale != 1 else camera for camera in parsed.cameras]
    if cameras is not None:
        cameras = [cameras] if isinstance(cameras, str) else list(cameras)
        by_name = {camera.name: camera for camera in found}
        unknown = [name for name in cameras if name not in by_name]
        if unknown:
            raise DataError(f"camera {unknown[0]}: {where} has no camera of that name (it has {', '.join(names)})")
        found = [by_name[name] for name in cameras]
    log.info("%s: units %s (%s)%s", where, units, reason, ": converted to mm" if units != "mm" else "")
    return Calibration(found, units, reason, path, parsed.format)


def write_opencv_yaml(path: str | Path, cameras: Sequence[Camera], units: str = "mm") -> Path:
    """Write ``cameras`` (translations in mm) as an OpenCV FileStorage YAML file (atomically)
    that :func:`read_calibration` reads back exactly: the sequence ``names``, ``units`` (mm or
    m), and one map per camera with ``K`` (3, 3), ``dist`` (1, 5), ``R`` (3, 3), ``t`` (3, 1) in
    ``units``,
    ``image_width``, ``image_height`` and ``colour`` (1 or 0). Returns the path.

    Raises:
        DataError: ``path`` does not end in ``.yml`` or ``.yaml``; a camera's name is not a
            FileStorage key (a letter or ``_``, then letters, digits, ``_``, ``-``, spaces)
            or is ``names`` or ``units``; two cameras share a name.
        WriteError: the file cannot be written.
    """
    path = Path(path)
    check_choice("calibration units", units, tuple(UNITS))
    if path.suffix not in (".yml", ".yaml"):
        raise DataError(f"cannot write the calibration {path} as OpenCV YAML: its name must end in .yml or .yaml")
    names = [camera.name for camera in cameras]
    for name in names:
        if not _FILESTORAGE_KEY.fullmatch(name) or name in _RESERVED:
            raise DataError(
                f"camera {name}: cannot be named in the OpenCV calibration {path}: a name must start "
                "with a letter or _ and hold only letters, digits, _, - and spaces, and not be "
                f"{' or '.join(_RESERVED)}"
            )
        if names.count(name) > 1:
            raise DataError(f"camera {name}: two cameras of that name to write to {path}")
    storage = cv2.FileStorage(path.name, cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    storage.write("names", names)
    storage.write("units", units)
    for camera in cameras:
        storage.startWriteStruct(camera.name, cv2.FileNode_MAP)
        storage.write("K", camera.K)
        storage.write("dist", camera.dist.reshape(1, 5))
        storage.write("R", camera.R)
        storage.write("t", camera.t.reshape(3, 1) / UNITS[units])
        storage.write("image_width", int(camera.width))
        storage.write("image_height", int(camera.height))
        storage.write("colour", int(camera.colour))
        storage.endWriteStruct()
    return write_text_atomic(path, storage.releaseAndGetString())


# --- units -------------------------------------------------------------------------------


def _decide_units(where: str, parsed: _Parsed, units: str, key: str) -> tuple[str, str]:
    """``(units, reason)`` of the translations of ``parsed``; see the module's docstring.
    Messages name the setting ``key``."""
    if parsed.stated_units is not None:
        if units not in ("auto", parsed.stated_units):
            raise DataError(
                f"{where} states that its translations are in {parsed.stated_units}, but "
                f"{key} is {units}; set {key} to {parsed.stated_units} or auto"
            )
        return parsed.stated_units, "stated in the file"
    if units != "auto":
        return units, f"as set by {key}"
    distances = np.array([np.linalg.norm(camera.centre) for camera in parsed.cameras])
    if not np.any(distances > 0):
        return "mm", "every camera at the world origin: the units make no difference"
    away = distances[distances > 1e-6 * distances.max()]
    low, median, high = float(away.min()), float(np.median(away)), float(away.max())
    if median < METRES_BELOW:
        detected = "m"
    elif median > MILLIMETRES_ABOVE:
        detected = "mm"
    else:
        raise DataError(
            f"{where}: cannot tell whether its translations are in mm or m: its cameras stand "
            f"{low:.4g}-{high:.4g} (median {median:.4g}) from the world origin, between "
            f"{METRES_BELOW:g} (metres) and {MILLIMETRES_ABOVE:g} (mm); set {key} to mm or m"
        )
    return detected, f"detected from camera distances {_rounded(low)}-{_rounded(high)} {detected}"


def _rounded(length: float) -> str:
    """``length`` to 3 significant digits, without an exponent below 10^6 (4.31, 4310)."""
    return f"{float(f'{length:.3g}'):g}"


# --- files and folders -------------------------------------------------------------------


def calibration_suffix(path: str | Path) -> str | None:
    """The suffix of :data:`CALIBRATION_FORMATS` that ``path``'s name ends in, in any case
    (the longest: ``Calib.qca.txt`` is ``.qca.txt``), or None."""
    name = Path(path).name.lower()
    return max((suffix for suffix in CALIBRATION_FORMATS if name.endswith(suffix)), key=len, default=None)


def _read_file(path: Path) -> _Parsed:
    suffix = calibration_suffix(path)
    if suffix is None:
        accepted = "; ".join(f"{s} ({f})" for s, f in CALIBRATION_FORMATS.items())
        raise DataError(
            f"calibration file {path}: unknown format {path.suffix or '(no suffix)'}; accepted: "
            f"{accepted}, or a folder of per-camera files"
        )
    if suffix == ".toml":
        return _read_toml(path)
    if suffix == ".qca.txt":
        return _read_qtm(path)
    if suffix == ".xcp":
        return _read_vicon(path)
    if suffix == ".json" and _is_mmocap_json(path):
        return _Parsed([Camera.load(path)], "mm", "mmocap calibration JSON")
    return _read_filestorage([path], path.stem, CALIBRATION_FORMATS[suffix])


def _is_mmocap_json(path: Path) -> bool:
    """True for a camera JSON of :meth:`Camera.save` (it holds ``t_mm``), False for any
    other (an OpenCV FileStorage JSON, or one that cannot be read, for FileStorage to name)."""
    try:
        return '"t_mm"' in path.read_text(errors="replace")
    except OSError as exc:
        raise DataError(f"calibration file {path} cannot be read: {exc.strerror}") from None


def _read_folder(folder: Path) -> _Parsed:
    if all((folder / name).is_file() for name in EASYMOCAP_FILES):
        return _read_filestorage([folder / name for name in EASYMOCAP_FILES], None, "EasyMocap intri.yml + extri.yml")
    files = sorted(p for p in folder.iterdir() if p.is_file() and calibration_suffix(p) is not None)
    kinds = sorted({"json" if calibration_suffix(p) == ".json" else "FileStorage" for p in files})
    if not files:
        raise DataError(
            f"calibration folder {folder} holds no calibration files (looked for "
            f"*{', *'.join(CALIBRATION_FORMATS)}, or {' and '.join(EASYMOCAP_FILES)})"
        )
    rig_files = [p for p in files if calibration_suffix(p) in RIG_FILE_SUFFIXES]
    if rig_files == files and len(files) == 1:
        return _read_file(files[0])
    if len(kinds) > 1 or rig_files:
        raise DataError(
            f"calibration folder {folder} mixes calibration formats "
            f"({', '.join(p.name for p in files)}); keep one camera file per camera, in one format, "
            "or pass the one calibration file instead of the folder"
        )
    parts = [_read_file(p) for p in files]
    for file, part in zip(files, parts, strict=True):
        if not part.cameras:
            raise DataError(
                f"calibration file {file} holds no camera ({part.format}: {part.expected}); "
                f"every file of the calibration folder {folder} must hold one"
            )
    stated = {part.stated_units for part in parts}
    if len(stated) > 1:
        raise DataError(
            f"calibration folder {folder}: its files state different units "
            f"({', '.join(sorted(str(s) for s in stated))}); give every camera the same units"
        )
    return _Parsed(
        [camera for part in parts for camera in part.cameras], stated.pop(), parts[0].format, parts[0].expected
    )


# --- OpenCV FileStorage --------------------------------------------------------------------


def _read_filestorage(paths: list[Path], single_name: str | None, format_name: str) -> _Parsed:
    """The cameras of FileStorage files read together (EasyMocap's two, or one).
    ``single_name`` names the camera of a file holding one camera's keys at the top level."""
    storages = [_open_filestorage(path) for path in paths]
    try:
        return _read_storages([storage.root() for storage in storages], paths, single_name, format_name)
    except UnicodeDecodeError as exc:  # OpenCV hands a damaged file's text on undecoded
        raise DataError(_not_utf8(" + ".join(str(p) for p in paths), exc)) from None
    finally:
        for storage in storages:
            storage.release()


def _read_storages(roots: list, paths: list[Path], single_name: str | None, format_name: str) -> _Parsed:
    """:func:`_read_filestorage` on the files' root nodes (whose FileStorage objects must
    stay open meanwhile: a node does not keep its file open)."""
    source = f"calibration file {' + '.join(str(p) for p in paths)}"

    def top(key: str):
        return next((value for value in (_top_value(root, key) for root in roots) if value is not None), None)

    stated = top("units")
    if stated is not None and stated not in UNITS:
        raise DataError(f"{source}: 'units' must be mm or m, got {stated!r}")
    names = top("names")
    if names is not None:
        names = [names] if isinstance(names, str) else names
        if not isinstance(names, list) or not all(isinstance(n, str) and n for n in names):
            raise DataError(f"{source}: 'names' must be a sequence of camera names, got {names!r:.80}")
        cameras = [_camera(source, name, _NamedKeys(roots, name)) for name in names]
    elif single_name is not None and _holds_camera(lambda key: _top_value(roots[0], key), ("K",)):
        cameras = [_camera(source, single_name, _MapKeys(lambda key: _top_value(roots[0], key), None))]
    else:
        cameras = []
        for root in roots:
            for key in root.keys():  # noqa: SIM118  # a cv2.FileNode, which has no __iter__ nor __contains__
                node = root.getNode(key)
                if node.isMap() and not _is_matrix(node) and _holds_camera(lambda k, n=node: _child_value(n, k)):  # type: ignore[misc]  # a lambda's default
                    cameras.append(_camera(source, key, _MapKeys(lambda k, n=node: _child_value(n, k), key)))  # type: ignore[misc]
    return _Parsed(
        cameras,
        stated,
        format_name,
        "looked for a sequence 'names', a camera matrix (K, camera_matrix, ...) at the top level, "
        "and maps holding camera keys",
    )


def _open_filestorage(path: Path) -> cv2.FileStorage:
    """The FileStorage file ``path``, opened; a DataError if it cannot be parsed, or if it is
    YAML (a file of lines) whose last line has no line end (:func:`mmocap.io.check_whole_lines`)."""
    if path.stat().st_size == 0:
        raise DataError(f"calibration file {path} is empty")
    if calibration_suffix(path) in (".yml", ".yaml"):
        check_whole_lines(path.read_bytes(), f"calibration file {path}")
    try:
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:  # OpenCV's Python binding wraps a parse error in a SystemError
        header = path.read_bytes()[:16].lstrip()
        hint = (
            ""
            if header.startswith((b"%YAML", b"<?xml", b"{"))
            else ("; OpenCV YAML starts with %YAML:1.0 or %YAML 1.2 (plain YAML, such as ROS camera_info, is not read)")
        )
        raise DataError(
            f"calibration file {path} cannot be read as OpenCV FileStorage "
            f"(%YAML:1.0 or %YAML 1.2 YAML, XML or JSON): {_cv_message(exc)}{hint}"
        ) from None
    if not storage.isOpened():
        raise DataError(f"calibration file {path} cannot be opened")
    if not storage.root().isMap():
        storage.release()
        raise DataError(f"calibration file {path} holds no keys at its top level")
    try:
        repeated = _repeated_key(storage.root(), "its top level")
    except UnicodeDecodeError as exc:  # OpenCV hands a damaged file's keys on undecoded
        storage.release()
        raise DataError(_not_utf8(str(path), exc)) from None
    if repeated is not None:
        storage.release()
        raise DataError(f"calibration file {path} gives the key {repeated}; keep one")
    return storage


def _not_utf8(source: str, exc: UnicodeDecodeError) -> str:
    return f"calibration file {source} holds text that is not UTF-8 ({exc.reason}); is it damaged? write it again"


def _repeated_key(node, where: str) -> str | None:
    """``'<key>' twice in <where>`` for the first key a FileStorage map ``node`` (or a map
    below it) gives twice, which FileStorage would read as its first value; None if none is."""
    keys = list(node.keys())
    twice = next((key for k, key in enumerate(keys) if key in keys[:k]), None)
    if twice is not None:
        return f"{twice!r} twice in {where}"
    for key in keys:
        child = node.getNode(key)
        if child.isMap() and (found := _repeated_key(child, f"the map {key}")) is not None:
            return found
    return None


def _cv_message(exc: Exception) -> str:
    """OpenCV's message of a cv2.error (or the one inside a SystemError) on one line, without
    OpenCV's source file: ``Parsing error at line 4: Missing , between the elements``."""
    text = " ".join(str(exc.__cause__ or exc).split())
    found = re.search(r"error: \(-?\d+:([^)]*)\) (.*?)(?: in function '(.*)')?$", text)
    if not found:
        return text
    kind, what, function = found.groups()
    at_line = re.fullmatch(r".*\((\d+)\): (.*)", function or "")
    return f"{kind} at line {at_line[1]}: {at_line[2]}" if at_line else f"{kind}: {what}"


def _top_value(root, key: str):
    return _node_value(root.getNode(key))


def _child_value(node, key: str):
    return _node_value(node.getNode(key))


def _is_matrix(node) -> bool:
    return node.isMap() and {"rows", "cols", "data"} <= set(node.keys())


def _node_value(node):
    """A FileStorage node as Python: a matrix as a numpy array, a sequence as a list, an
    integer as int, a real as float, a string as str, a map as a dict; None if missing."""
    if node.empty() or node.isNone():
        return None
    if node.isMap():
        if _is_matrix(node):
            try:
                return node.mat()
            except cv2.error:  # rows, cols and data, but no dt: some other map
                pass
        return {key: _node_value(node.getNode(key)) for key in node.keys()}  # noqa: SIM118  # a cv2.FileNode
    if node.isSeq():
        return [_node_value(node.at(i)) for i in range(node.size())]
    if node.isInt():
        return int(node.real())
    if node.isReal():
        return node.real()
    if node.isString():
        return node.string()
    return None


class _MapKeys:
    """A camera's values under plain keys (a map per camera, a TOML table, a file's top level)."""

    def __init__(self, value: Callable[[str], object], map_name: str | None):
        self.value, self.map_name = value, map_name

    def get(self, spellings: Sequence[str]) -> tuple[str, object] | None:
        return next(((key, v) for key in spellings if (v := self.value(key)) is not None), None)

    def describe(self, spellings: Sequence[str]) -> str:
        where = f" in the map {self.map_name}" if self.map_name else ""
        return f"one of the keys {', '.join(spellings)}{where}"


class _NamedKeys:
    """A camera of a ``names`` list: its values in a map of its name, or in top-level keys
    suffixed with its name (EasyMocap), looked up in each FileStorage root in turn."""

    def __init__(self, roots, name: str):
        self.roots, self.name = roots, name

    def _lookup(self, key: str):
        for root in self.roots:
            camera_map = root.getNode(self.name)
            if (
                camera_map.isMap()
                and not _is_matrix(camera_map)
                and (value := _child_value(camera_map, key)) is not None
            ):
                return value
            if (value := _top_value(root, f"{key}_{self.name}")) is not None:
                return value
        return None

    def get(self, spellings: Sequence[str]) -> tuple[str, object] | None:
        return next(((key, v) for key in spellings if (v := self._lookup(key)) is not None), None)

    def describe(self, spellings: Sequence[str]) -> str:
        return (
            f"one of the keys {', '.join(spellings)} in the map {self.name}, or "
            f"{', '.join(f'{key}_{self.name}' for key in spellings)} at the top level"
        )


def _holds_camera(value: Callable[[str], object], which: Sequence[str] = ("K", "dist", "R", "t")) -> bool:
    """True if any spelling of the keys ``which`` is there."""
    return any(value(key) is not None for what in which for key in KEYS[what][1])


# --- TOML ----------------------------------------------------------------------------------


def _read_toml(path: Path) -> _Parsed:
    source = f"calibration file {path}"
    try:
        document = tomllib.loads(read_lines_file(path, source, errors="strict"))
    except tomllib.TOMLDecodeError as exc:
        raise DataError(f"{source} is not valid TOML: {' '.join(str(exc).split())}") from None
    except UnicodeDecodeError as exc:
        raise DataError(f"{source} is not valid TOML: not UTF-8 text ({exc.reason})") from None
    cameras = []
    for table_name, table in document.items():
        if table_name in TOML_SKIPPED or not isinstance(table, dict):
            continue
        name = table.get("name", table_name)
        if not isinstance(name, str) or not name:
            raise DataError(f"camera {table_name}: {source}: 'name' must be a non-empty string, got {name!r}")
        cameras.append(_camera(source, name, _MapKeys(table.get, f"[{table_name}]")))
    return _Parsed(
        cameras, None, CALIBRATION_FORMATS[".toml"], f"looked for tables other than {', '.join(TOML_SKIPPED)}"
    )


# --- Qualisys QTM and Vicon XML --------------------------------------------------------------


def _xml_root(path: Path, tag: str, format_name: str) -> ET.Element:
    """The root element of the XML file ``path``, which must be ``<tag>``; a DataError if the
    file cannot be read or parsed."""
    source = f"calibration file {path}"
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, LookupError, ValueError) as exc:  # a damaged declaration names an unknown encoding
        raise DataError(f"{source} is not valid XML ({format_name}): {exc}") from None
    except OSError as exc:
        raise DataError(f"{source} cannot be read: {exc.strerror}") from None
    if root.tag != tag:
        raise DataError(f"{source} is not a {format_name}: its root element is <{root.tag}>, expected <{tag}>")
    return root


class _XmlCamera:
    """One camera's XML element, its children and attributes read with one-line DataErrors
    naming the file, the camera and the attribute."""

    def __init__(self, source: str, name: str, element: ET.Element):
        self.source, self.name, self.element = source, name, element

    def fail(self, element: ET.Element, attribute: str, problem: str) -> DataError:
        return DataError(f"camera {self.name}: {self.source}: <{element.tag}> attribute '{attribute}' {problem}")

    def child(self, path: str) -> ET.Element:
        """The one element at ``path`` below the camera's."""
        found = self.element.findall(path)
        if len(found) != 1:
            problem = "lacks the element" if not found else f"has {len(found)} elements"
            raise DataError(f"camera {self.name}: {self.source}: its <{self.element.tag}> {problem} <{path}>")
        return found[0]

    def text(self, element: ET.Element, attribute: str) -> str:
        value = (element.get(attribute) or "").strip()
        if not value:
            raise DataError(
                f"camera {self.name}: {self.source}: <{element.tag}> lacks the attribute '{attribute}' (or it is empty)"
            )
        return value

    def numbers(self, element: ET.Element, attribute: str, counts: Sequence[int] = (1,), words: str = "a number"):
        """(n,) the finite numbers of ``attribute``, separated by spaces, n in ``counts``;
        ``words`` says what they are in messages."""
        text = self.text(element, attribute)
        try:
            values = np.array([float(token) for token in text.split()])
        except ValueError:
            raise self.fail(element, attribute, f"must be {words}, got {text!r:.80}") from None
        if values.size not in counts:
            raise self.fail(element, attribute, f"must be {words}, got {text!r:.80}")
        if not np.all(np.isfinite(values)):
            raise self.fail(element, attribute, f"must be finite, got {text!r:.80}")
        return values

    def number(self, element: ET.Element, attribute: str, default: float | None = None) -> float:
        if default is not None and element.get(attribute) is None:
            return default
        return float(self.numbers(element, attribute)[0])

    def zero_skew(self, element: ET.Element, attribute: str) -> None:
        skew = self.number(element, attribute, default=0.0)
        if skew != 0:
            raise self.fail(
                element, attribute, f"is {skew:g}: a skewed sensor is not supported (its units are unknown)"
            )


def _read_qtm(path: Path) -> _Parsed:
    """The active cameras of a Qualisys QTM ``.qca.txt`` (see the module's docstring)."""
    source = f"calibration file {path}"
    root = _xml_root(path, "calibration", "Qualisys QTM calibration")
    cameras: list[Camera] = []
    serials: dict[str, int] = {}
    for index, element in enumerate(root.findall("cameras/camera"), 1):
        name = _XmlCamera(source, f"#{index}", element).text(element, "serial")
        camera = _XmlCamera(source, name, element)
        if name in serials:
            raise camera.fail(element, "serial", f"{name!r} is also the serial of camera #{serials[name]}")
        serials[name] = index
        active = element.get("active", "1").strip()
        if active not in ("0", "1"):
            raise camera.fail(element, "active", f"must be 1 or 0, got {active!r}")
        if active == "0":
            log.info('camera %s: %s: inactive (active="0"): left out', name, source)
            continue
        cameras.append(_qtm_camera(camera))
    return _Parsed(cameras, "mm", CALIBRATION_FORMATS[".qca.txt"], 'looked for <camera active="1"> in <cameras>')


def _qtm_camera(camera: _XmlCamera) -> Camera:
    """One QTM camera, translation in mm."""
    fov, intrinsic, transform = (camera.child(tag) for tag in ("fov_video", "intrinsic", "transform"))
    left, top, right, bottom = (camera.number(fov, side) for side in ("left", "top", "right", "bottom"))
    fu, fv, cu, cv_ = (
        camera.number(intrinsic, key) / QTM_SUBPIXELS
        for key in ("focalLengthU", "focalLengthV", "centerPointU", "centerPointV")
    )
    camera.zero_skew(intrinsic, "skew")
    k1, k2, k3, p1, p2 = (
        camera.number(intrinsic, key)
        for key in (
            "radialDistortion1",
            "radialDistortion2",
            "radialDistortion3",
            "tangentalDistortion1",
            "tangentalDistortion2",
        )
    )
    rotation = np.array([[camera.number(transform, f"r{i}{j}") for j in (1, 2, 3)] for i in (1, 2, 3)])
    centre = np.array([camera.number(transform, axis) for axis in ("x", "y", "z")])
    turn = camera.element.get("viewrotation", "0").strip()
    if turn not in ("0", "90", "180", "270"):
        raise camera.fail(camera.element, "viewrotation", f"must be 0, 90, 180 or 270, got {turn!r}")
    if turn != "0":
        log.warning(
            "camera %s: %s: viewrotation %s: read as its sensor sees it, unturned: its videos must not be turned",
            camera.name,
            camera.source,
            turn,
        )
    R = QTM_TO_OPENCV @ rotation
    return checked_camera(
        camera.source,
        camera.name,
        np.array([[fu, 0.0, cu - left], [0.0, fv, cv_ - top], [0.0, 0.0, 1.0]]),
        np.array([k1, k2, p1, p2, k3]),
        R,
        -R @ centre,
        _whole(right - left + 1),
        _whole(bottom - top + 1),
        keys={
            "K": "<intrinsic> focalLengthU, focalLengthV, centerPointU, centerPointV",
            "dist": "<intrinsic> radialDistortion1-3, tangentalDistortion1-2",
            "R": "<transform> r11-r33",
            "t_mm": "<transform> x, y, z",
            "width": "<fov_video> left, right",
            "height": "<fov_video> top, bottom",
        },
    )


def _read_vicon(path: Path) -> _Parsed:
    """The cameras of a Vicon ``.xcp`` (see the module's docstring)."""
    source = f"calibration file {path}"
    root = _xml_root(path, "Cameras", "Vicon calibration")
    cameras: list[Camera] = []
    names: dict[str, int] = {}
    for index, element in enumerate(root.findall("Camera"), 1):
        attribute = next((key for key in VICON_NAMES if (element.get(key) or "").strip()), None)
        if attribute is None:
            raise DataError(
                f"camera #{index}: {source}: <Camera> lacks the attributes {', '.join(VICON_NAMES)} that name it"
            )
        name = element.get(attribute, "").strip()
        camera = _XmlCamera(source, name, element)
        if name in names:
            raise camera.fail(element, attribute, f"{name!r} also names camera #{names[name]}")
        names[name] = index
        cameras.append(_vicon_camera(camera))
    return _Parsed(cameras, "mm", CALIBRATION_FORMATS[".xcp"], "looked for <Camera> in <Cameras>")


def _vicon_camera(camera: _XmlCamera) -> Camera:
    """One Vicon camera, translation in mm."""
    element = camera.element
    keyframes = element.findall("KeyFrames/KeyFrame")
    if len(keyframes) > 1:
        raise DataError(
            f"camera {camera.name}: {camera.source}: {len(keyframes)} <KeyFrame>s: a moving camera, which "
            "mmocap does not support; calibrate the cameras standing still"
        )
    keyframe = camera.child("KeyFrames/KeyFrame")
    width, height = camera.numbers(element, "SENSOR_SIZE", (2,), "width height in pixels")
    aspect = camera.number(element, "PIXEL_ASPECT_RATIO")
    if aspect <= 0:
        raise camera.fail(element, "PIXEL_ASPECT_RATIO", f"must be > 0, got {aspect:g}")
    camera.zero_skew(element, "SKEW")
    focal = camera.number(keyframe, "FOCAL_LENGTH")
    cx, cy = camera.numbers(keyframe, "PRINCIPAL_POINT", (2,), "x y in pixels")
    quaternion = camera.numbers(keyframe, "ORIENTATION", (4,), "a quaternion x y z w")
    norm = float(np.linalg.norm(quaternion))
    if abs(norm - 1) > ROTATION_TOLERANCE:
        raise camera.fail(keyframe, "ORIENTATION", f"must be a unit quaternion x y z w, got norm {norm:g}")
    position = camera.numbers(keyframe, "POSITION", (3,), "x y z in mm")
    R = _quaternion_matrix(quaternion / norm)
    return checked_camera(
        camera.source,
        camera.name,
        np.array([[focal, 0.0, cx], [0.0, focal / aspect, cy], [0.0, 0.0, 1.0]]),
        _vicon_distortion(camera, keyframe, (cx, cy)),
        R,
        -R @ position,
        _whole(float(width)),
        _whole(float(height)),
        keys={
            "K": "FOCAL_LENGTH, PIXEL_ASPECT_RATIO, PRINCIPAL_POINT",
            "R": "ORIENTATION",
            "t_mm": "POSITION",
            "width": "SENSOR_SIZE",
            "height": "SENSOR_SIZE",
        },
    )


def _vicon_distortion(camera: _XmlCamera, keyframe: ET.Element, principal_point: tuple[float, float]) -> np.ndarray:
    """(5,) ``k1 k2 0 0 k3`` from ``VICON_RADIAL2`` (``<model> <centre x> <centre y> k1 k2
    [k3]``) or else ``VICON_RADIAL`` (``k1 k2``); a warning if the distortion's centre stands
    more than :data:`VICON_CENTRE_PX` from ``principal_point`` (x, y in pixels), on which
    mmocap centres it."""
    if keyframe.get("VICON_RADIAL2") is None:
        if keyframe.get("VICON_RADIAL") is None:
            raise DataError(
                f"camera {camera.name}: {camera.source}: <KeyFrame> lacks the lens distortion: give the "
                "attribute 'VICON_RADIAL2' or 'VICON_RADIAL'"
            )
        k1, k2 = camera.numbers(keyframe, "VICON_RADIAL", (2,), "k1 k2")
        return np.array([k1, k2, 0.0, 0.0, 0.0])
    text = camera.text(keyframe, "VICON_RADIAL2")
    try:
        values = [float(token) for token in text.split()[1:]]
    except ValueError:
        values = []
    if len(values) not in (4, 5) or not np.all(np.isfinite(values)):
        words = "<model> <centre x> <centre y> k1 k2 [k3], finite (or give VICON_RADIAL: k1 k2)"
        raise camera.fail(keyframe, "VICON_RADIAL2", f"must be {words}, got {text!r:.80}")
    offset = float(np.hypot(values[0] - principal_point[0], values[1] - principal_point[1]))
    if offset > VICON_CENTRE_PX:
        log.warning(
            "camera %s: %s: the distortion's centre in VICON_RADIAL2 stands %.3g px from PRINCIPAL_POINT: "
            "the distortion is taken about the principal point",
            camera.name,
            camera.source,
            offset,
        )
    k1, k2, k3 = [*values[2:], 0.0][:3]
    return np.array([k1, k2, 0.0, 0.0, k3])


def _quaternion_matrix(quaternion: np.ndarray) -> np.ndarray:
    """(3, 3) rotation of the unit quaternion ``(x, y, z, w)``, real part last."""
    x, y, z, w = quaternion
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


# --- one camera ----------------------------------------------------------------------------


def _camera(source: str, name: str, keys: _MapKeys | _NamedKeys) -> Camera:
    """The camera ``name`` from ``keys``' values (translation in the file's units)."""

    def fail(key: str, problem: str) -> DataError:
        return DataError(f"camera {name}: {source}: '{key}' {problem}")

    def missing(words: str, spellings: Sequence[str]) -> DataError:
        return DataError(f"camera {name}: {source} lacks the {words}: give {keys.describe(spellings)}")

    def required(what: str) -> tuple[str, object]:
        found = keys.get(KEYS[what][1])
        if found is None:
            raise missing(*KEYS[what])
        return found

    fisheye = keys.get(KEYS["fisheye"][1])
    if fisheye is not None and fisheye[1] not in (False, 0):
        raise fail(
            fisheye[0],
            f"is {fisheye[1]!r}: fisheye lenses are not supported (mmocap's lens model is "
            "OpenCV's pin-hole one, k1 k2 p1 p2 k3); calibrate with the standard model",
        )
    k_key, K = required("K")
    dist_key, dist = required("dist")
    r_key, rotation = required("R")
    t_key, t = required("t")
    width_height = _image_size(keys, missing, fail)
    colour = keys.get(KEYS["colour"][1])
    colour_key, colour_value = colour if colour is not None else ("colour", True)
    if is_real(colour_value) and colour_value in (0, 1):
        colour_value = bool(colour_value)
    R = _rotation(r_key, rotation, fail)
    t = _array(t_key, t, fail)
    if t.size == 3:
        t = t.reshape(3)
    labels = {
        "K": k_key,
        "dist": dist_key,
        "R": r_key,
        "t_mm": t_key,
        "width": width_height[0][0],
        "height": width_height[1][0],
        "colour": colour_key,
    }
    return checked_camera(
        source,
        name,
        K,
        _distortion(dist_key, dist, fail),
        R,
        t,
        width_height[0][1],
        width_height[1][1],
        colour_value,
        keys=labels,
    )


def _array(key: str, value, fail) -> np.ndarray:
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise fail(key, f"must hold numbers, got {value!r:.80}") from None


def _distortion(key: str, value, fail) -> np.ndarray:
    """(5,) ``k1 k2 p1 p2 k3`` from OpenCV's 4, 5, 8, 12 or 14 coefficients (a row, a
    column or a list); nonzero coefficients beyond the fifth are refused."""
    coefficients = _array(key, value, fail)
    if coefficients.ndim == 2 and 1 in coefficients.shape:
        coefficients = coefficients.ravel()
    if coefficients.ndim != 1 or coefficients.size not in DISTORTION_COUNTS:
        raise fail(
            key,
            f"must be {', '.join(map(str, DISTORTION_COUNTS[:-1]))} or {DISTORTION_COUNTS[-1]} "
            f"distortion coefficients (k1 k2 p1 p2 [k3 ...]), got shape {coefficients.shape}",
        )
    extra = {n: c for n, c in zip(DISTORTION_NAMES[5:], coefficients[5:], strict=False) if c != 0}
    if extra:
        listed = ", ".join(f"{n} = {c:g}" for n, c in extra.items())
        raise fail(
            key,
            f"has nonzero coefficients beyond k1 k2 p1 p2 k3 ({listed}), which mmocap's lens model "
            "cannot represent; calibrate again without OpenCV's rational, thin-prism and tilted models "
            "(CALIB_RATIONAL_MODEL, CALIB_THIN_PRISM_MODEL, CALIB_TILTED_MODEL)",
        )
    return np.concatenate([coefficients[:5], np.zeros(5 - min(5, coefficients.size))])


def _rotation(key: str, value, fail) -> np.ndarray:
    """(3, 3) rotation from a matrix or a Rodrigues vector (3, (3, 1) or (1, 3))."""
    rotation = _array(key, value, fail)
    if rotation.shape in ((3,), (3, 1), (1, 3)):
        if not np.all(np.isfinite(rotation)):
            raise fail(key, f"must hold finite numbers, got {rotation.ravel().tolist()}")
        return cv2.Rodrigues(rotation.reshape(3, 1))[0]
    if rotation.shape != (3, 3):
        raise fail(key, f"must be a 3 x 3 rotation matrix or a Rodrigues vector of 3, got shape {rotation.shape}")
    return rotation


def _image_size(keys: _MapKeys | _NamedKeys, missing, fail) -> tuple[tuple[str, object], tuple[str, object]]:
    """``((width key, width), (height key, height))`` from ``image_width`` and
    ``image_height`` or from ``size = [width, height]``; whole floats become ints."""
    width, height = keys.get(KEYS["width"][1]), keys.get(KEYS["height"][1])
    if width is None or height is None:
        size = keys.get(KEYS["size"][1])
        if size is None:
            raise missing("image size in pixels", (*KEYS["width"][1], *KEYS["height"][1], *KEYS["size"][1]))
        size_key, value = size
        flat = np.asarray(value, dtype=object).ravel() if isinstance(value, (list, np.ndarray)) else None
        if flat is None or flat.size != 2:
            raise fail(size_key, f"must be [width, height] in pixels, got {value!r:.80}")
        width, height = (size_key, flat[0]), (size_key, flat[1])
    return (width[0], _whole(width[1])), (height[0], _whole(height[1]))


def _whole(value):
    """``value`` as an int if it is a whole real number (Pose2Sim writes ``1920.0``)."""
    if is_real(value) and math.isfinite(value) and float(value).is_integer():
        return int(value)
    return value
