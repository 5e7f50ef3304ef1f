"""The Cano paper's Tables 1 and 2 (and Fig. 3) for this machine, on the synthetic
benchmark scene (:class:`mmocap.testing.scene.Scene`).

Table 2 (``model-view``): time to project the model and count its pixels in one 640x480
view, per backend and vertex level, from a population evaluated in one camera (so the
host work, body kinematics at least, is included), best of ``repeats`` runs; speed-up
against ``naive`` timed in the same run.

Table 1 (``frame``): time per frame of CMA-ES (holistic, 39 DOF) with a budget of
evaluations and 7 cameras, split into the time spent evaluating solutions and the rest,
the mean over ``frames`` frames and more (up to :data:`MAX_FRAMES`) while they fit in
``seconds``; frames per second (also plotted against the budget as Fig. 3) and the host's
share of the frame. ``naive`` would take minutes per frame: its frame time is extrapolated
from its Table 2 time per model-view (evaluations x cameras x that time), and marked so.
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from mmocap import registry
from mmocap.evaluators.timed import TimedEvaluator
from mmocap.stages.tracking import Holistic
from mmocap.testing.scene import Scene

MAX_FRAMES = 5  # frames per budget and backend that frame_ms adds to fill its seconds


def model_view_us(ev, scene: Scene, population: int, repeats: int) -> float:
    """Best time per model-view in microseconds: ``population`` candidates, camera 0."""
    ev.setup(scene.body, scene.cameras[:1], scene.foreground[:1])
    X = scene.candidates(population)
    ev(X[:1])  # warm-up: kernels, caches, workers
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        ev(X)
        best = min(best, time.perf_counter() - start)
    return best / population * 1e6


def frame_ms(ev, scene: Scene, budget: int, frames: int, seconds: float = 0.0) -> tuple[float, float]:
    """Mean (frame, solutions) time in ms of CMA-ES on ``frames`` frames of ``budget``, and
    on more (up to ``MAX_FRAMES``) as long as the next one is likely to end within
    ``seconds`` of the start: one frame of a fast backend is too noisy a figure."""
    strategy, total, solutions, done = Holistic(), 0.0, 0.0, 0
    rng = np.random.default_rng(budget)
    ev.setup(scene.body, scene.cameras, scene.foreground)
    ev(scene.candidates(2))  # warm-up: kernels, caches, workers
    while done < max(frames, 1) or (done < MAX_FRAMES and total * (done + 1) / done < seconds):
        done += 1
        optimizer = registry.make_optimizer("cmaes")
        timed = TimedEvaluator(ev)
        x_prev = scene.pose + scene.noise(rng, 1, 0.05)[0]
        start = time.perf_counter()
        ev.setup(scene.body, scene.cameras, scene.foreground)
        strategy.estimate(scene.body, x_prev, timed, optimizer, budget, rng)
        total += time.perf_counter() - start
        solutions += timed.seconds
    return total / done * 1e3, solutions / done * 1e3


def table2(evaluators: dict, scenes: dict, population: int, repeats: int) -> pd.DataFrame:
    """Time per model-view (us) per backend and vertex level, with the speed-up vs naive."""
    rows = []
    for vertices, scene in scenes.items():
        for name, ev in evaluators.items():
            n, r = (2, 1) if name == "naive" else (population, repeats)
            us = model_view_us(ev, scene, n, r)
            rows.append({"vertices": vertices, "backend": name, "us_per_model_view": us})
            print(f"table 2: {vertices} vertices, {name}: {us:.1f} us per model-view", flush=True)
    df = pd.DataFrame(rows)
    if "naive" in evaluators:
        naive = df[df.backend == "naive"].set_index("vertices").us_per_model_view
        df["speedup_vs_naive"] = naive.loc[df.vertices].to_numpy() / df.us_per_model_view
    return df


def table1(evaluators: dict, scenes: dict, budgets, frames: int, naive_us: dict, seconds: float = 0.0) -> pd.DataFrame:
    """Frame and solutions time (ms) of CMA-ES per backend, vertex level and budget; fps;
    the host's share of the frame (the time not spent evaluating: CMA-ES, the strategy, the
    evaluator's setup). ``frames`` and ``seconds`` as for :func:`frame_ms`."""
    rows = []
    for vertices, scene in scenes.items():
        C = len(scene.cameras)
        for budget in budgets:
            for name, ev in evaluators.items():
                if name == "naive":
                    if vertices not in naive_us:
                        continue
                    solutions = budget * C * naive_us[vertices] / 1e3
                    rows.append(
                        {
                            "vertices": vertices,
                            "evaluations": budget,
                            "backend": name,
                            "frame_ms": solutions,
                            "solutions_ms": solutions,
                            "extrapolated": True,
                        }
                    )
                    continue
                frame, solutions = frame_ms(ev, scene, budget, frames, seconds)
                rows.append(
                    {
                        "vertices": vertices,
                        "evaluations": budget,
                        "backend": name,
                        "frame_ms": frame,
                        "solutions_ms": solutions,
                        "extrapolated": False,
                    }
                )
                print(
                    f"table 1: {vertices} vertices, {budget} evaluations, {name}: "
                    f"{frame:.0f} ms per frame ({solutions:.0f} ms evaluating)",
                    flush=True,
                )
    df = pd.DataFrame(rows)
    df["fps"] = 1e3 / df.frame_ms
    df["host_share"] = 1 - df.solutions_ms / df.frame_ms
    if naive_us:
        key = ["vertices", "evaluations"]
        naive = df[df.backend == "naive"].set_index(key)
        index = pd.MultiIndex.from_frame(df[key])
        df["speedup_vs_naive"] = naive.frame_ms.reindex(index).to_numpy() / df.frame_ms
    return df
