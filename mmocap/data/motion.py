"""Plausible synthetic motion for the actions walking, gestures and boxing.

Motion is written directly as full 51-entry pose vectors (mm, rad; see
:mod:`mmocap.body.skeleton`), so the ground truth lies in the tracker's 39-DOF space, while
the images are rendered from the linear-blend-skinned full mesh.  Every sequence adds
smooth, seeded per-joint variation (sums of slow sines) on all 39 axes, the wrists,
ankles and upper spine included, so that no two sequences are identical and the 28-DOF
model cannot represent the motion exactly.
"""

from __future__ import annotations

import numpy as np

from mmocap.body.skeleton import N_FULL, dof_mask, limits, parameter_index
from mmocap.errors import ConfigError

ACTIONS = ("walking", "gestures", "boxing")


class _Pose:
    """Frames x 51 pose array addressed by parameter name, e.g. ``p["LKnee.rx"] = ...``."""

    def __init__(self, n: int):
        self.X = np.zeros((n, N_FULL))

    def __setitem__(self, name: str, value) -> None:
        self.X[:, parameter_index(name)] = value

    def __getitem__(self, name: str) -> np.ndarray:
        return self.X[:, parameter_index(name)]


def _bump(phase: np.ndarray, centre: float, width: float) -> np.ndarray:
    """Periodic Gaussian bump of the gait phase (rad) around ``centre``."""
    d = np.angle(np.exp(1j * (phase - centre)))
    return np.exp(-0.5 * (d / width) ** 2)


def _smooth_noise(t: np.ndarray, rng: np.random.Generator, amplitude: float) -> np.ndarray:
    """(n, 51) smooth variation: three random sines per axis, 0.1-0.8 Hz."""
    freqs = rng.uniform(0.1, 0.8, size=(3, N_FULL))
    phases = rng.uniform(0, 2 * np.pi, size=(3, N_FULL))
    amps = rng.uniform(0.3, 1.0, size=(3, N_FULL)) * amplitude / 2
    return np.einsum("kd,nkd->nd", amps, np.sin(2 * np.pi * freqs[None] * t[:, None, None] + phases[None]))


def _arms_down(p: _Pose, amount: float = 0.55) -> None:
    """Bring the A-pose arms towards the body (+Rz adducts the left arm, -Rz the right)."""
    p["LShoulder.rz"] = amount
    p["RShoulder.rz"] = -amount


def walking(t: np.ndarray, p: _Pose, rng: np.random.Generator) -> None:
    """Walking on a circle of radius 1.2 m around the origin at about 1.1 m/s."""
    period = rng.uniform(1.0, 1.15)
    speed, radius = rng.uniform(1.0, 1.2), 1200.0
    phase = 2 * np.pi * t / period + rng.uniform(0, 2 * np.pi)
    angle = speed * 1000 * t / radius + rng.uniform(0, 2 * np.pi)
    p["Root.tx"] = radius * np.cos(angle)
    p["Root.tz"] = -radius * np.sin(angle)
    heading = angle + np.pi  # tangent to the circle, walking counter-clockwise seen from above
    p["Root.ry"] = np.unwrap(heading)
    p["Root.ty"] += -25 + 12 * np.cos(2 * phase)
    p["Root.rx"] = 0.05 + 0.03 * np.cos(2 * phase)
    p["Root.rz"] = 0.04 * np.sin(phase)
    p["BottomSpine.ry"] = 0.08 * np.sin(phase)
    p["BottomSpine.rx"] = 0.04
    p["UpperSpine.ry"] = 0.05 * np.sin(phase)
    for side, shift in (("L", 0.0), ("R", np.pi)):
        ph = phase + shift
        p[f"{side}Hip.rx"] = -0.12 + 0.38 * np.sin(ph)
        p[f"{side}Knee.rx"] = 0.08 + 0.95 * _bump(ph, 0.95 * np.pi, 0.5) + 0.22 * _bump(ph, 1.7 * np.pi, 0.3)
        p[f"{side}Ankle.rx"] = 0.1 * np.sin(ph + 0.5) + 0.3 * _bump(ph, 0.6 * np.pi, 0.3)
        p[f"{side}Shoulder.ry"] = 0.05 + 0.32 * np.sin(ph)
        p[f"{side}Elbow.ry"] = -0.5 + 0.25 * (1 + np.sin(ph)) / 2
    _arms_down(p)


def gestures(t: np.ndarray, p: _Pose, rng: np.random.Generator) -> None:
    """Standing still, the right hand waving and the left arm pointing now and then."""
    p["Root.ry"] = rng.uniform(-np.pi, np.pi)
    p["Root.tx"], p["Root.tz"] = rng.uniform(-300, 300, size=2)
    p["Root.ty"] += -10
    sway = np.sin(2 * np.pi * 0.3 * t)
    p["Root.rz"] = 0.02 * sway
    _arms_down(p)
    raise_r = 0.5 * (1 - np.cos(np.clip(2 * np.pi * t / 3.0, 0, np.pi)))  # up within 1.5 s
    wave = np.sin(2 * np.pi * rng.uniform(1.5, 2.2) * t)
    p["RShoulder.rz"] = -0.55 + 1.9 * raise_r
    p["RShoulder.ry"] = 0.3 * raise_r
    p["RElbow.ry"] = raise_r * (1.3 + 0.45 * wave)
    p["RWrist.rz"] = 0.3 * raise_r * wave
    point = np.clip(np.sin(2 * np.pi * 0.35 * t + rng.uniform(0, 2 * np.pi)), 0, None)
    p["LShoulder.ry"] = 0.1 + 1.1 * point
    p["LElbow.ry"] = -0.6 + 0.5 * (1 - point)
    p["Neck.ry"] = 0.25 * np.sin(2 * np.pi * 0.4 * t)
    p["BottomSpine.ry"] = 0.12 * np.sin(2 * np.pi * 0.25 * t)


def boxing(t: np.ndarray, p: _Pose, rng: np.random.Generator) -> None:
    """Guard stance with alternating punches every ~0.7 s, torso twisting into each one."""
    p["Root.ry"] = rng.uniform(-np.pi, np.pi)
    p["Root.tx"], p["Root.tz"] = rng.uniform(-300, 300, size=2)
    p["Root.ty"] += -60 + 15 * np.sin(2 * np.pi * 1.5 * t)
    p["BottomSpine.rx"] = 0.15
    for side in "LR":
        p[f"{side}Hip.rx"] = -0.3
        p[f"{side}Knee.rx"] = 0.45
        p[f"{side}Ankle.rx"] = -0.15
    p["LHip.rz"], p["RHip.rz"] = 0.12, -0.12
    interval = rng.uniform(0.6, 0.8)
    k = np.floor(t / interval)
    s = (t - k * interval) / interval  # 0..1 within each punch
    punch = np.sin(np.pi * s) ** 2  # out and back again
    left = (k % 2 == 0).astype(float)
    for side, active, sign in (("L", left, 1.0), ("R", 1 - left, -1.0)):
        extend = punch * active
        p[f"{side}Shoulder.rz"] = sign * (0.75 - 0.2 * extend)
        p[f"{side}Shoulder.ry"] = 0.9 + 0.55 * extend
        p[f"{side}Elbow.ry"] = 1.7 - 2.0 * extend
        p[f"{side}Wrist.ry"] = 0.2 * extend
    p["BottomSpine.ry"] = 0.3 * punch * (2 * left - 1)
    p["Neck.rx"] = 0.1


def generate_motion(
    action: str,
    n_frames: int,
    fps: float,
    floor_offset_mm: float,
    seed: int = 0,
    variation_rad: float = 0.05,
    turn_deg: float = 0.0,
) -> np.ndarray:
    """(n_frames, 51) ground-truth poses of one action, clipped to the joint limits.

    ``floor_offset_mm`` is the root height of the standing rest pose (feet on y = 0);
    ``turn_deg`` turns the whole motion about the vertical axis through the world's origin
    (the person faces and moves that many degrees further round, the cameras stay).
    """
    generators = {"walking": walking, "gestures": gestures, "boxing": boxing}
    if action not in generators:
        raise ConfigError(f"unknown action '{action}'; known: {', '.join(ACTIONS)}")
    if n_frames < 1 or fps <= 0:
        raise ConfigError(f"need n_frames >= 1 and fps > 0, got {n_frames} and {fps}")
    rng = np.random.default_rng(seed)
    t = np.arange(n_frames) / fps
    p = _Pose(n_frames)
    p["Root.ty"] = floor_offset_mm
    generators[action](t, p, rng)
    rotations = dof_mask(39).copy()
    rotations[:3] = False
    p.X[:, rotations] += _smooth_noise(t, rng, variation_rad)[:, rotations]
    turn = np.radians(turn_deg)
    x, z = p["Root.tx"].copy(), p["Root.tz"].copy()
    p["Root.tx"] = x * np.cos(turn) + z * np.sin(turn)
    p["Root.tz"] = -x * np.sin(turn) + z * np.cos(turn)
    p["Root.ry"] = p["Root.ry"] + turn
    lower, upper = limits()
    return np.clip(p.X, lower, upper)
