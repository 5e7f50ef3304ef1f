"""The plugin passes mmocap's optimiser conformance suite and runs from the command line."""

import json
import subprocess
import sys

import numpy as np
from mmocap_pycma.optimizer import PycmaOptimizer

from mmocap.api import SearchSpace
from mmocap.data.synthetic import generate
from mmocap.testing.objectives import minimise
from mmocap.testing.optimizers import OptimizerConformance


class TestPycma(OptimizerConformance):
    name = "pycma"


def test_solves_a_rotated_ellipsoid():
    # Condition 1e4 in a rotated frame: needs the covariance adaptation pycma provides.
    dim = 10
    rotation, _ = np.linalg.qr(np.random.default_rng(0).standard_normal((dim, dim)))
    scales = 1e4 ** (np.arange(dim) / (dim - 1))

    def ellipsoid(X):
        return np.sum(scales * ((X - 0.2) @ rotation) ** 2, axis=1)

    space = SearchSpace(x0=np.zeros(dim), lower=-np.ones(dim), upper=np.ones(dim), radius=np.ones(dim), budget=8000)
    result = minimise(PycmaOptimizer(sigma0=0.3), ellipsoid, space, seed=0).result
    assert result.fbest < 1e-8


def test_tracks_from_the_command_line(tmp_path):
    root = tmp_path / "data"
    generate(
        root / "S1_walking",
        subject="S1",
        action="walking",
        frames=2,
        cameras=("C1", "BW1"),
        width=160,
        height=120,
        background_frames=3,
        seed=1,
        progress=False,
    )
    out = tmp_path / "run"
    args = [
        f"dataset.root={root}",
        "dataset.frames=2",
        "dataset.cameras=[C1,BW1]",
        "dataset.all_cameras=[C1,BW1]",
        "dataset.width=160",
        "dataset.height=120",
        "dataset.background_frames=3",
        "dataset.seed=1",
        "progress=false",
        "overlays=0",
        "tracking.evaluations=200",
        "optimizer=pycma",
        f"hydra.run.dir={out}",
    ]
    proc = subprocess.run([sys.executable, "-m", "mmocap", *args], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["optimizer"] == "pycma"
    assert summary["frames"] == 2
    assert summary["evaluations_used"] <= 2 * 200
    assert summary["mean_marker_error_mm"] < 60
