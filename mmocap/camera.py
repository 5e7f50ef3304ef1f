"""Calibrated pin-hole cameras with OpenCV-order lens distortion (stage: undistortion).

Conventions: world points in millimetres; ``X_cam = R @ X_world + t`` (t in mm); pixel
coordinates follow OpenCV, the centre of pixel (col, row) being at (col, row).
Distortion coefficients are ``(k1, k2, p1, p2, k3)`` as in ``cv2.projectPoints``.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np

from mmocap.errors import DataError


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
        = K, so the ideal image keeps the same intrinsics) and cached.
        """
        if "undistort" not in self._maps:
            self._maps["undistort"] = cv2.initUndistortRectifyMap(
                self.K, self.dist, None, self.K, (self.width, self.height), cv2.CV_32FC1
            )
        return self._maps["undistort"]

    def undistort_mask(self, mask: np.ndarray) -> np.ndarray:
        """(H, W) bool mask seen through the lens -> (H, W) bool mask of the ideal camera."""
        if not np.any(self.dist):
            return mask
        mx, my = self.undistort_maps()
        out = cv2.remap(mask.astype(np.uint8), mx, my, cv2.INTER_NEAREST,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        return out.astype(bool)

    # --- construction and storage -------------------------------------------------------

    @staticmethod
    def look_at(name: str, eye_mm, target_mm, focal_px: float, width: int, height: int,
                dist=(0, 0, 0, 0, 0), colour: bool = True, up=(0.0, 1.0, 0.0)) -> Camera:
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
        return {
            "name": self.name, "width": self.width, "height": self.height,
            "colour": self.colour, "K": self.K.tolist(), "dist": self.dist.tolist(),
            "R": self.R.tolist(), "t_mm": self.t.tolist(),
        }

    def save(self, path: Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=2))

    def save_cal(self, path: Path) -> None:
        """Write a HumanEva-I ``.cal`` file: 22 numbers, one per line (see :meth:`load_cal`)."""
        K = self.K
        numbers = [K[0, 0], K[1, 1], K[0, 2], K[1, 2], K[0, 1] / K[0, 0], *self.dist,
                   *self.R.ravel(), *self.t]
        Path(path).write_text("".join(f"{v:.17g}\n" for v in numbers))

    @staticmethod
    def load_cal(path: Path, width: int, height: int, colour: bool = True,
                 name: str | None = None) -> Camera:
        """Read a HumanEva-I ``.cal`` file (Bouguet's calibration toolbox parameters).

        It holds 22 numbers separated by white space: fc (2, pixels), cc (2, pixels, the
        centre of the top-left pixel being (0, 0) as in OpenCV), alpha_c (1, skew as a
        fraction of fc[0]), kc (5, ``k1 k2 p1 p2 k3``), R (9, row-major) and T (3, mm), with
        ``X_cam = R X + T``.  The file holds no image size: ``width`` and ``height`` come
        from the images.  ``name`` defaults to the file's stem.
        """
        path = Path(path)
        if not path.is_file():
            raise DataError(f"calibration file not found: {path}")
        tokens = path.read_text(errors="replace").split()
        try:
            v = np.array([float(t) for t in tokens])
        except ValueError as exc:
            raise DataError(f"calibration file {path}: non-numeric value ({exc})") from None
        if v.size != 22:
            raise DataError(f"calibration file {path} holds {v.size} numbers, a .cal file has 22 "
                            "(fc 2, cc 2, alpha_c 1, kc 5, R 9, T 3)")
        if not np.all(np.isfinite(v)):
            raise DataError(f"calibration file {path}: values must be finite")
        fc, cc, alpha, kc, R, T = v[0:2], v[2:4], v[4], v[5:10], v[10:19].reshape(3, 3), v[19:22]
        if np.any(fc <= 0):
            raise DataError(f"calibration file {path}: focal lengths {fc.tolist()} must be > 0")
        if abs(np.linalg.det(R) - 1) > 1e-3 or not np.allclose(R @ R.T, np.eye(3), atol=1e-3):
            raise DataError(f"calibration file {path}: R is not a rotation matrix")
        K = np.array([[fc[0], alpha * fc[0], cc[0]], [0.0, fc[1], cc[1]], [0.0, 0.0, 1.0]])
        return Camera(name or path.stem, K, kc, R, T, int(width), int(height), colour)

    @staticmethod
    def load(path: Path) -> Camera:
        """Read a calibration JSON written by :meth:`save`; errors name the file and field."""
        path = Path(path)
        if not path.is_file():
            raise DataError(f"calibration file not found: {path}")
        try:
            d = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise DataError(f"calibration file {path} is not valid JSON: {exc}") from None
        shapes = {"K": (3, 3), "dist": (5,), "R": (3, 3), "t_mm": (3,)}
        arrays = {}
        for key, shape in shapes.items():
            try:
                a = np.asarray(d[key], dtype=np.float64)
            except KeyError:
                raise DataError(f"calibration file {path} lacks the field '{key}'") from None
            except (TypeError, ValueError):
                raise DataError(f"calibration file {path}: field '{key}' is not numeric") from None
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise DataError(f"calibration file {path}: field '{key}' must be {shape} "
                                f"finite numbers, got shape {a.shape}")
            arrays[key] = a
        try:
            width, height = int(d["width"]), int(d["height"])
        except (KeyError, TypeError, ValueError):
            raise DataError(f"calibration file {path} needs integer 'width' and 'height'") from None
        if width <= 0 or height <= 0:
            raise DataError(f"calibration file {path}: image size {width}x{height} is not positive")
        if abs(np.linalg.det(arrays["R"]) - 1) > 1e-3:
            raise DataError(f"calibration file {path}: 'R' is not a rotation matrix")
        return Camera(str(d.get("name", path.stem)), arrays["K"], arrays["dist"], arrays["R"],
                      arrays["t_mm"], width, height, bool(d.get("colour", True)))
