"""Calibrated pin-hole cameras with OpenCV-order lens distortion (stage: undistortion).

Conventions: world points in millimetres; ``X_cam = R @ X_world + t`` (t in mm); pixel
coordinates follow OpenCV, the centre of pixel (col, row) being at (col, row).
Distortion coefficients are ``(k1, k2, p1, p2, k3)`` as in ``cv2.projectPoints``.
``K[0, 1]`` is the skew (Bouguet's ``alpha_c * fc[0]``): the distorted pixel of normalised
lens coordinates ``(xd, yd)`` is ``K @ (xd, yd, 1)``. OpenCV's distortion functions read only
``fx, fy, cx, cy`` of a camera matrix and drop the skew; :meth:`Camera.project` and
:meth:`Camera.undistort_maps` keep it.

Every calibration reader builds its cameras with :func:`checked_camera`, the one validation
of a camera's values whatever file they come from.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np

from mmocap.errors import DataError
from mmocap.io import read_json_object, read_lines_file
from mmocap.validate import is_integer

#: Largest image side, in pixels, that a calibration may give: a bigger size is taken for a
#: mistake (60000x40000 would allocate gigabytes of maps and masks) and refused.
MAX_IMAGE_SIDE_PX = 16384
#: How far outside the image the principal point may lie, as a fraction of its width
#: (height): beyond that the calibration belongs to another image size or is wrong.
PRINCIPAL_POINT_MARGIN = 0.5
#: Largest deviation of ``R @ R.T`` from the identity and of ``det(R)`` from 1.
ROTATION_TOLERANCE = 1e-3
#: The keys a calibration JSON must hold (``name`` and ``colour`` are optional).
JSON_KEYS = ("K", "dist", "R", "t_mm", "width", "height")
#: Shapes of the array keys.
SHAPES = {"K": (3, 3), "dist": (5,), "R": (3, 3), "t_mm": (3,)}
#: :func:`checked_camera`'s keys under the names of a HumanEva-I ``.cal`` file.
CAL_KEYS = {"K": "fc, cc, alpha_c", "dist": "kc", "t_mm": "T"}
#: The most steps :meth:`Camera.ideal_pixels` takes to invert the lens distortion.
UNDISTORT_ITERATIONS = 100


@dataclass(frozen=True)
class Camera:
    """One calibrated camera.

    Attributes:
        name: camera name, e.g. ``"C1"`` or ``"BW2"``.
        K: (3, 3) intrinsic matrix in pixels.
        dist: (5,) distortion ``k1, k2, p1, p2, k3``.
        R: (3, 3) world-to-camera rotation.
        t: (3,) world-to-camera translation in mm.
        width, height: image size in pixels.
        colour: True for a colour sensor, False for greyscale.
    """

    name: str
    K: np.ndarray
    dist: np.ndarray
    R: np.ndarray
    t: np.ndarray
    width: int
    height: int
    colour: bool = True
    _maps: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def focal(self) -> float:
        """Mean focal length in pixels."""
        return float(0.5 * (self.K[0, 0] + self.K[1, 1]))

    @property
    def centre(self) -> np.ndarray:
        """(3,) camera centre in world coordinates, mm."""
        return -self.R.T @ self.t

    @property
    def extrinsic(self) -> np.ndarray:
        """(4, 4) world-to-camera transform E (the Cano paper's E_c)."""
        E = np.eye(4)
        E[:3, :3] = self.R
        E[:3, 3] = self.t
        return E

    @property
    def projection_matrix(self) -> np.ndarray:
        """(3, 4) ideal pin-hole projection K [R | t]."""
        return self.K @ self.extrinsic[:3]

    def ideal(self) -> Camera:
        """The same camera without lens distortion (what the evaluators use)."""
        return replace(self, dist=np.zeros(5), _maps={})

    def shrunk_pixels(self, pixels: np.ndarray, shrunk: Camera) -> np.ndarray:
        """(..., 2) pixels of this camera -> the same points' pixels in ``shrunk``, this
        camera's :meth:`shrunk` (``u' = (u + 0.5) s - 0.5`` per axis)."""
        scale = np.array([shrunk.width / self.width, shrunk.height / self.height])
        return (np.asarray(pixels, np.float64) + 0.5) * scale - 0.5

    def shrunk(self, scale: float, min_side_px: int = 1) -> Camera:
        """The camera imaging a ``scale`` times smaller picture (lens distortion, which acts
        before ``K``, unchanged): the size rounded to whole pixels (at least ``min_side_px``),
        ``K`` scaled per axis by the rounded ratio, pixel centres kept at integer coordinates
        (OpenCV's convention: ``u' = (u + 0.5) s - 0.5``)."""
        width = max(min_side_px, round(self.width * scale))
        height = max(min_side_px, round(self.height * scale))
        sx, sy = width / self.width, height / self.height
        S = np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5], [0.0, 0.0, 1.0]])
        return replace(self, K=S @ np.asarray(self.K, np.float64), width=width, height=height, _maps={})

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) world points in mm -> (N, 3) camera-frame points in mm."""
        return points @ self.R.T + self.t

    def project(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) world points in mm -> (N, 2) pixel coordinates, with lens distortion.

        Agrees with ``cv2.projectPoints`` for points in front of the camera.
        """
        pc = self.to_camera(np.asarray(points, dtype=np.float64))
        z = pc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = pc[:, 0] / z
            y = pc[:, 1] / z
        k1, k2, p1, p2, k3 = self.dist
        r2 = x * x + y * y
        radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        u = self.K[0, 0] * xd + self.K[0, 1] * yd + self.K[0, 2]
        v = self.K[1, 1] * yd + self.K[1, 2]
        return np.stack([u, v], axis=1)

    def undistort_maps(self) -> tuple[np.ndarray, np.ndarray]:
        """Maps for ``cv2.remap`` from a distorted image to the ideal pin-hole image.

        Computed once per camera with ``cv2.initUndistortRectifyMap`` (new camera matrix
        = K, so the ideal image keeps the same intrinsics) and cached. OpenCV distorts
        without the skew; the map's columns are then sheared by it, so that each ideal
        pixel maps to where :meth:`project` puts its ray.
        """
        if "undistort" not in self._maps:
            unskewed = self.K.copy()
            unskewed[0, 1] = 0.0
            map_x, map_y = cv2.initUndistortRectifyMap(
                unskewed, self.dist, None, self.K, (self.width, self.height), cv2.CV_32FC1
            )
            if self.K[0, 1]:
                # (map_x, map_y) = (fx xd + cx, fy yd + cy); the skewed column adds skew * yd
                map_x = (map_x + (self.K[0, 1] / self.K[1, 1]) * (map_y - self.K[1, 2])).astype(np.float32)
            self._maps["undistort"] = (map_x, map_y)
        return self._maps["undistort"]

    def ideal_pixels(self, pixels: np.ndarray) -> np.ndarray:
        """(N, 2) pixels of the image seen through the lens -> (N, 2) pixels of the ideal
        pin-hole camera (:meth:`ideal`): the inverse of :meth:`project`'s distortion, as
        :meth:`undistort_maps` is for images.

        The skew is taken out before ``cv2.undistortPointsIter`` (which reads ``fx, fy, cx,
        cy`` only) and put back by ``K``; the iteration runs until it moves by under 1e-12 of
        a normalised coordinate (at most :data:`UNDISTORT_ITERATIONS` steps).
        """
        pixels = np.asarray(pixels, np.float64).reshape(-1, 2)
        if not np.any(self.dist) or len(pixels) == 0:
            return pixels.copy()
        K = self.K
        yd = (pixels[:, 1] - K[1, 2]) / K[1, 1]
        xd = (pixels[:, 0] - K[0, 2] - K[0, 1] * yd) / K[0, 0]
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, UNDISTORT_ITERATIONS, 1e-12)
        lens = np.stack([xd, yd], axis=1)[:, None, :]
        identity = np.eye(3)
        x, y = cv2.undistortPointsIter(lens, identity, self.dist, identity, identity, criteria).reshape(-1, 2).T
        return np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=1)

    def undistort_mask(self, mask: np.ndarray) -> np.ndarray:
        """(H, W) bool mask seen through the lens -> (H, W) bool mask of the ideal camera."""
        if not np.any(self.dist):
            return mask
        mx, my = self.undistort_maps()
        out = cv2.remap(mask.astype(np.uint8), mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        return out.astype(bool)

    # --- construction and storage -------------------------------------------------------

    @staticmethod
    def look_at(
        name: str,
        eye_mm,
        target_mm,
        focal_px: float,
        width: int,
        height: int,
        dist=(0, 0, 0, 0, 0),
        colour: bool = True,
        up=(0.0, 1.0, 0.0),
    ) -> Camera:
        """A camera at ``eye_mm`` looking at ``target_mm`` with image rows going down."""
        eye = np.asarray(eye_mm, float)
        forward = np.asarray(target_mm, float) - eye
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, np.asarray(up, float))
        right /= np.linalg.norm(right)
        down = np.cross(forward, right)
        R = np.stack([right, down, forward])
        K = np.array([[focal_px, 0, (width - 1) / 2], [0, focal_px, (height - 1) / 2], [0, 0, 1.0]])
        return Camera(name, K, np.asarray(dist, float), R, -R @ eye, int(width), int(height), colour)

    def to_dict(self) -> dict:
        """The camera as JSON-ready values: ``name``, ``width``, ``height`` (px), ``colour``, ``K``
        (px), ``dist``, ``R`` and ``t_mm`` (mm), read back by :meth:`load`."""
        return {
            "name": self.name,
            "width": self.width,
            "height": self.height,
            "colour": self.colour,
            "K": self.K.tolist(),
            "dist": self.dist.tolist(),
            "R": self.R.tolist(),
            "t_mm": self.t.tolist(),
        }

    def save(self, path: Path) -> None:
        """Write the calibration JSON of :meth:`to_dict` to ``path``."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=2))

    def save_cal(self, path: Path) -> None:
        """Write a HumanEva-I ``.cal`` file: 22 numbers, one per line (see :meth:`load_cal`)."""
        K = self.K
        numbers = [K[0, 0], K[1, 1], K[0, 2], K[1, 2], K[0, 1] / K[0, 0], *self.dist, *self.R.ravel(), *self.t]
        Path(path).write_text("".join(f"{v:.17g}\n" for v in numbers))

    @staticmethod
    def load_cal(path: Path, width: int, height: int, colour: bool = True, name: str | None = None) -> Camera:
        """Read a HumanEva-I ``.cal`` file (Bouguet's calibration toolbox parameters).

        It holds 22 numbers separated by white space: fc (2, pixels), cc (2, pixels, the
        centre of the top-left pixel being (0, 0) as in OpenCV), alpha_c (1, skew as a
        fraction of fc[0]), kc (5, ``k1 k2 p1 p2 k3``), R (9, row-major) and T (3, mm), with
        ``X_cam = R X + T``.  The file holds no image size: ``width`` and ``height`` come
        from the images.  ``name`` defaults to the file's stem.  The values are checked by
        :func:`checked_camera`; errors name the file, the camera and the ``.cal`` field. A file
        whose last line has no line end is read as HumanEva distributes it, with a warning that
        it may be cut inside its last number (:func:`mmocap.io.check_whole_lines`).
        """
        path = Path(path)
        name = name or path.stem
        if not path.is_file():
            raise DataError(f"camera {name}: calibration file not found: {path}")
        tokens = read_lines_file(path, f"camera {name}: calibration file {path}", unended="warn").split()
        try:
            v = np.array([float(t) for t in tokens])
        except ValueError as exc:
            raise DataError(f"camera {name}: calibration file {path}: non-numeric value ({exc})") from None
        if v.size != 22:
            raise DataError(
                f"camera {name}: calibration file {path} holds {v.size} numbers, a .cal file has 22 "
                "(fc 2, cc 2, alpha_c 1, kc 5, R 9, T 3)"
            )
        fc, cc, alpha, kc, R, T = v[0:2], v[2:4], v[4], v[5:10], v[10:19].reshape(3, 3), v[19:22]
        K = np.array([[fc[0], alpha * fc[0], cc[0]], [0.0, fc[1], cc[1]], [0.0, 0.0, 1.0]])
        return checked_camera(f"calibration file {path}", name, K, kc, R, T, width, height, colour, keys=CAL_KEYS)

    @staticmethod
    def load(path: Path) -> Camera:
        """Read a calibration JSON written by :meth:`save` (the keys of :meth:`to_dict`;
        ``name`` defaults to the file's stem and ``colour`` to true). The values are
        checked by :func:`checked_camera`; errors name the file, the camera and the key."""
        path = Path(path)
        if not path.is_file():
            raise DataError(f"camera {path.stem}: calibration file not found: {path}")
        where = f"camera {path.stem}: calibration file {path}"
        d = read_json_object(path, name=where, wanted=f"a JSON object with the keys {', '.join(JSON_KEYS)}")
        missing = [key for key in JSON_KEYS if key not in d]
        if missing:
            raise DataError(f"{where} lacks the field '{missing[0]}' (it needs {', '.join(JSON_KEYS)})")
        name = d.get("name", path.stem)
        if not isinstance(name, str) or not name:
            raise DataError(f"{where}: field 'name' must be a non-empty string, got {name!r}")
        return checked_camera(
            f"calibration file {path}",
            name,
            d["K"],
            d["dist"],
            d["R"],
            d["t_mm"],
            d["width"],
            d["height"],
            d.get("colour", True),
        )


def checked_camera(
    source: str, name: str, K, dist, R, t, width, height, colour=True, keys: dict[str, str] | None = None
) -> Camera:
    """A :class:`Camera` from the values a calibration reader parsed, after checking every
    one: the validation that every reader (JSON, HumanEva-I ``.cal``, any future one) uses.

    Args:
        source: where the values come from, for messages (``"calibration file <path>"``).
        name: the camera's name.
        K (np.ndarray): (3, 3) intrinsics in pixels: ``fx, fy > 0``, any finite skew ``K[0, 1]``,
            ``K[1, 0] = K[2, 0] = K[2, 1] = 0`` and ``K[2, 2] = 1``, the principal point
            at most :data:`PRINCIPAL_POINT_MARGIN` of the image size outside the image.
        dist (np.ndarray): (5,) finite ``k1, k2, p1, p2, k3``.
        R (np.ndarray): (3, 3) world-to-camera rotation: orthonormal with determinant +1,
            within :data:`ROTATION_TOLERANCE`.
        t (np.ndarray): (3,) finite translation in mm.
        width (int): the image width, an integer in 1..:data:`MAX_IMAGE_SIDE_PX` pixels,
            checked first (as the height), so that an absurd size is refused before anything
            allocates.
        height (int): the image height, likewise.
        colour (bool): True for a colour sensor, False for greyscale.
        keys: the reader's names for the keys ``K``, ``dist``, ``R``, ``t_mm``, ``width``,
            ``height`` and ``colour`` where they differ (e.g. HumanEva's ``kc`` for ``dist``).

    Raises:
        DataError: one line naming ``source``, the camera and the key.
    """
    label = {key: key for key in ("K", "dist", "R", "t_mm", "width", "height", "colour")} | (keys or {})

    def fail(key: str, problem: str) -> DataError:
        return DataError(f"camera {name}: {source}: '{label[key]}' {problem}")

    for key, value in (("width", width), ("height", height)):
        if not is_integer(value) or not 1 <= value <= MAX_IMAGE_SIDE_PX:
            raise fail(
                key,
                f"must be an integer number of pixels in [1, {MAX_IMAGE_SIDE_PX}] "
                f"(the largest image side mmocap accepts), got {value!r}",
            )
    if not isinstance(colour, (bool, np.bool_)):
        raise fail("colour", f"must be true or false, got {colour!r}")
    arrays = {}
    for key, value in (("K", K), ("dist", dist), ("R", R), ("t_mm", t)):
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise fail(key, f"must be {_shape_words(SHAPES[key])} numbers, got {value!r:.80}") from None
        if array.shape != SHAPES[key]:
            raise fail(key, f"must be {_shape_words(SHAPES[key])} numbers, got shape {array.shape}")
        if not np.all(np.isfinite(array)):
            raise fail(key, f"must hold finite numbers, got {array.tolist()}")
        arrays[key] = array
    K = arrays["K"]
    if K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
        raise fail("K", f"must be [[fx, skew, cx], [0, fy, cy], [0, 0, 1]], got {K.tolist()}")
    if K[0, 0] <= 0 or K[1, 1] <= 0:
        raise fail("K", f"focal lengths fx = {K[0, 0]:g}, fy = {K[1, 1]:g} pixels must be > 0")
    for axis, centre, size in (("cx", K[0, 2], width), ("cy", K[1, 2], height)):
        low, high = -PRINCIPAL_POINT_MARGIN * size, (1 + PRINCIPAL_POINT_MARGIN) * size
        if not low <= centre <= high:
            raise fail(
                "K",
                f"principal point {axis} = {centre:g} lies far outside the {width}x{height} "
                f"image (allowed: [{low:g}, {high:g}]): a calibration of another image size?",
            )
    R = arrays["R"]
    if (
        not np.allclose(R @ R.T, np.eye(3), rtol=0, atol=ROTATION_TOLERANCE)
        or abs(np.linalg.det(R) - 1) > ROTATION_TOLERANCE
    ):
        raise fail(
            "R",
            f"is not a rotation matrix (R R^T = I and det R = +1 within {ROTATION_TOLERANCE:g}; "
            f"det R = {np.linalg.det(R):.6g})",
        )
    return Camera(name, K, arrays["dist"], R, arrays["t_mm"], int(width), int(height), bool(colour))


def _shape_words(shape: tuple[int, ...]) -> str:
    return " x ".join(map(str, shape)) if len(shape) > 1 else str(shape[0])
