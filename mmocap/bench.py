"""Evaluator benchmark: the Cano paper's Tables 1 and 2 (and Fig. 3) for this machine.

Table 2 (``model-view``): time to project the model and count its pixels in one 640x480
view, per backend and vertex level, from a population evaluated in one camera (so the
host work, body kinematics at least, is included), best of
``repeats`` runs; speed-up against ``naive`` timed in the same run.

Table 1 (``frame``): time per frame of CMA-ES (holistic, 39 DOF) with a budget of
evaluations and 7 cameras, split into the time spent evaluating solutions and the rest,
the mean over ``--frames`` frames and more (up to 5) while they fit in ``--seconds``;
frames per second, also plotted against the budget (Fig. 3, ``fig3.png``), and the host's
share of the frame. ``naive`` would
take minutes per frame: its frame time is extrapolated from its Table 2 time per model-view
(evaluations x cameras x that time), and marked so.

Roofline (``roofline``, and in ``all`` with the opencl backend): what one model-view at the
largest vertex level needs of float32 arithmetic, cache reads and local-memory ORs, this
device's measured rate of each, the floor that follows
(:mod:`mmocap.evaluators.roofline`) and the kernel's Table 2 time beside it.

Multi-fidelity (``fidelity``): the demo sequence (S1 walking, 4 cameras, 640x480) on
``realistic`` data, tracked by the real pipeline with holistic CMA-ES, exactly at each of
``--exact`` evaluations per frame and with each ``--schedule`` of cheaper fitness levels
before a short exact search (:mod:`mmocap.stages.fidelity`; carried on, or restarted per level
when a level names a popsize), one run at a time, each with every search seed of
``--seeds`` (a single seed's error moves by 1-2 mm): mean marker error and search time per
frame averaged over the seeds side by side, the error's spread over the seeds, their ratios to
the exact run at 1500 evaluations, and the Pareto front of both modes (``fidelity.png``).

Scene: the MakeHuman body resampled to the vertex level, cameras of the synthetic ring
(no lens distortion), the foreground being the model's own silhouettes of a reference
pose; candidates are that pose with normal noise on the joint angles.

Usage::

    mmocap bench table2 --vertices 27393,20544,13695
    mmocap bench table1 --budgets 500,1500,3000,5000
    mmocap bench roofline --backends opencl --vertices 27393
    mmocap bench all --vertices 27393 --budgets 500,1500 --prefix bench_
    mmocap bench fidelity --exact 500,1000,1500 --schedule 0.25:3000:1200+300
"""
from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from mmocap import registry
from mmocap.analysis.figures import plot_frames_per_second, plot_pareto_front
from mmocap.analysis.pareto import non_dominated
from mmocap.body.model import VERTICES_RANGE, BodyModel
from mmocap.config import compose
from mmocap.data.synthetic import CAMERA_RING, camera_rig
from mmocap.errors import ConfigError
from mmocap.evaluators import roofline
from mmocap.evaluators.timed import TimedEvaluator
from mmocap.optimizers.cmaes import strategy_parameters
from mmocap.pipeline import run
from mmocap.stages.fidelity import check_levels
from mmocap.stages.tracking import MAX_EVALUATIONS, START_EVALUATIONS, Holistic
from mmocap.validate import check_number

MAX_FRAMES = 5  # frames per budget and backend that frame_ms adds to fill its seconds
#: the multi-fidelity runs of ``mmocap bench fidelity`` unless ``--schedule`` is given
DEFAULT_SCHEDULES = ["0.25:3000:1000+350", "0.5:3000:1200+500:28", "0.5:3000:1400+400:28", "0.5:3000:1400+500:28"]


def backends() -> list[str]:
    """The default ``--backends``: every installed evaluator that can run here but ``auto``
    (which runs one of them), ``naive`` (the speed-ups' reference) first."""
    names = sorted(registry.available("evaluator"), key=lambda name: (name != "naive", name))
    return [name for name in names
            if name != "auto" and registry.unavailable("evaluator", name) is None]


class Scene:
    """Body at a vertex level, ``cameras`` 640x480 cameras and their foreground masks."""

    def __init__(self, vertices: int, cameras: int = 7, seed: int = 0):
        rng = np.random.default_rng(seed)
        self.body = BodyModel(vertices=vertices)
        names = [name for name, _, _ in CAMERA_RING][:cameras]
        self.cameras = camera_rig(names, 640, 480, rng, distortion=0.0)
        self.pose = self.body.rest_pose() + self.noise(rng, 1, 0.15)[0]
        with registry.make_evaluator("numpy") as ev:
            ev.setup(self.body, self.cameras, [np.zeros((480, 640), bool)] * cameras)
            self.foreground = [ev.render(self.pose, c) for c in range(cameras)]

    def noise(self, rng: np.random.Generator, n: int, radians: float) -> np.ndarray:
        """(n, 51) normal noise of ``radians`` on the active joint angles, none on the root."""
        scale = np.where(np.arange(51) >= 6, radians, 0.0) * self.body.mask
        return rng.normal(0.0, 1.0, (n, 51)) * scale

    def candidates(self, n: int, seed: int = 1) -> np.ndarray:
        """(n, 51) poses around the reference pose."""
        return self.pose + self.noise(np.random.default_rng(seed), n, 0.05)


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


def frame_ms(ev, scene: Scene, budget: int, frames: int,
             seconds: float = 0.0) -> tuple[float, float]:
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


def table1(evaluators: dict, scenes: dict, budgets, frames: int, naive_us: dict,
           seconds: float = 0.0) -> pd.DataFrame:
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
                    rows.append({"vertices": vertices, "evaluations": budget, "backend": name,
                                 "frame_ms": solutions, "solutions_ms": solutions,
                                 "extrapolated": True})
                    continue
                frame, solutions = frame_ms(ev, scene, budget, frames, seconds)
                rows.append({"vertices": vertices, "evaluations": budget, "backend": name,
                             "frame_ms": frame, "solutions_ms": solutions, "extrapolated": False})
                print(f"table 1: {vertices} vertices, {budget} evaluations, {name}: "
                      f"{frame:.0f} ms per frame ({solutions:.0f} ms evaluating)", flush=True)
    df = pd.DataFrame(rows)
    df["fps"] = 1e3 / df.frame_ms
    df["host_share"] = 1 - df.solutions_ms / df.frame_ms
    if naive_us:
        key = ["vertices", "evaluations"]
        naive = df[df.backend == "naive"].set_index(key)
        index = pd.MultiIndex.from_frame(df[key])
        df["speedup_vs_naive"] = naive.frame_ms.reindex(index).to_numpy() / df.frame_ms
    return df


def write_roofline(vertices: int, kernel_us: float, out: Path, prefix: str) -> None:
    """The silhouette kernel's roofline (:mod:`mmocap.evaluators.roofline`) on the default
    OpenCL device at ``vertices`` and 640x480, written as ``{prefix}roofline``: per resource
    what a model-view needs, the measured rate and the microseconds that follow; the floor
    (the largest); and the kernel as measured (``kernel_us``, Table 2), with its ratio to
    the floor."""
    rates, device = roofline.measure()
    us, need = roofline.floor_us(rates, vertices, 640, 480), roofline.needs(vertices, 640, 480)
    rows = [{"resource": "float32 arithmetic", "need_per_model_view": f"{need['flops']} flop",
             "measured_rate": f"{rates.flops / 1e9:.1f} Gflop/s", "us_per_model_view": us["arithmetic"]},
            {"resource": "reads (cache-resident)", "need_per_model_view": f"{need['bytes'] / 1e3:.0f} kB",
             "measured_rate": f"{rates.read_bytes / 1e9:.1f} GB/s", "us_per_model_view": us["reads"]},
            {"resource": "local memory: clear, scattered ORs",
             "need_per_model_view": f"{need['words']} words, {need['ors']} ORs",
             "measured_rate": f"{rates.clear_words / 1e9:.2f} Gword/s, {rates.ors / 1e9:.2f} GOR/s",
             "us_per_model_view": us["scatter"]},
            {"resource": "floor (the largest)", "need_per_model_view": "", "measured_rate": "",
             "us_per_model_view": us["floor"]},
            {"resource": "silhouette kernel (Table 2)", "need_per_model_view": "", "measured_rate": "",
             "us_per_model_view": kernel_us}]
    df = pd.DataFrame(rows)
    df["ratio_to_floor"] = df.us_per_model_view / us["floor"]
    print(f"roofline: {device}: floor {us['floor']:.1f} us, kernel {kernel_us:.1f} us per model-view", flush=True)
    write(df, out, f"{prefix}roofline",
          f"Roofline of the silhouette kernel: one 640x480 model-view at {vertices} vertices, microseconds")


#: the exact run the multi-fidelity runs are compared with: CMA-ES at this many evaluations
FIDELITY_REFERENCE = 1500
#: the run every fidelity configuration shares (the demo sequence on realistic data, as the
#: papers' tables track, without the recovery searches, whose extra evaluations vary)
FIDELITY_RUN = ["+experiment=demo", "realism=realistic", "recovery.enabled=false", "overlays=0",
                "progress=false", "foreground_cache=null"]


@dataclass(frozen=True)
class Search:
    """One search of the fidelity benchmark: its label (the text it was given), the cheaper
    levels (``fidelity.levels``, [] for an exact search), the exact evaluations per frame and
    CMA-ES's population size (None: the default, Table 2's)."""

    label: str
    levels: list
    exact: int
    popsize: int | None = None

    @property
    def carry(self) -> bool:
        """Carried on unless a level names its own optimiser settings (then restarted)."""
        return not any("optimizer" in level for level in self.levels)

    @property
    def mode(self) -> str:
        return "exact" if not self.levels else f"multi-fidelity ({'carried' if self.carry else 'restarted'})"

    def overrides(self, frames: int, seed: int) -> list[str]:
        """The config overrides of one run of this search (after :data:`FIDELITY_RUN`)."""
        popsize = [] if self.popsize is None else [f"optimizer.popsize={self.popsize}"]
        return [f"seed={seed}", f"tracking.frames={frames}", f"tracking.evaluations={self.exact}",
                f"fidelity.levels={self.levels}".replace("'", ""), f"fidelity.carry={self.carry}", *popsize]


def exact_part(text: str, option: str) -> tuple[int, int | None]:
    """'EVALUATIONS[:POPSIZE]' -> (evaluations, popsize or None), checked; a ConfigError
    naming ``option`` otherwise."""
    evaluations, _, popsize = text.partition(":")
    try:
        evaluations, popsize = int(evaluations), int(popsize) if popsize else None  # type: ignore[assignment]  # parsed
    except ValueError:
        raise ConfigError(f"{option} must be EVALUATIONS[:POPSIZE], e.g. 1500 or 1500:28, got {text!r}") from None
    check_number(option, evaluations, START_EVALUATIONS + 1, MAX_EVALUATIONS, integer=True)
    if popsize is not None:
        check_number(f"{option}'s popsize", popsize, 2, 10_000, integer=True)
    return evaluations, popsize  # type: ignore[return-value]  # parsed above


def parse_exact(text: str) -> list[Search]:
    """``--exact`` 'EVALUATIONS[:POPSIZE][,...]' (e.g. '1000,1500,1500:28') -> exact searches."""
    items = [item.strip() for item in text.split(",") if item.strip()]
    if not items:
        raise ConfigError(f"--exact must be EVALUATIONS[:POPSIZE][,...], e.g. 1000,1500:28, got {text!r}")
    return [Search(item, [], *exact_part(item, "--exact")) for item in items]


def parse_schedule(text: str) -> Search:
    """``--schedule`` 'SCALE:VERTICES:EVALUATIONS[:POPSIZE][,...]+EXACT[:POPSIZE]' (e.g.
    '0.25:3000:1200:28+300' or '0.25:1000:1400+400:28') -> its search: the levels, carried on
    with the whole search's population size after EXACT, or restarted when a level names its
    own; a ConfigError naming it otherwise."""
    levels_text, _, exact = text.partition("+")
    syntax = (f"--schedule must be SCALE:VERTICES:EVALUATIONS[:POPSIZE][,...]+EXACT[:POPSIZE], e.g. "
              f"0.25:3000:1200:28+300 or 0.25:1000:1400+400:28, got {text!r}")
    try:
        levels = []
        for level in levels_text.split(","):
            scale, vertices, evaluations, *popsize = level.split(":")
            if len(popsize) > 1:
                raise ValueError(level)
            levels.append({"scale": float(scale), "vertices": int(vertices), "evaluations": int(evaluations),
                           **({"optimizer": {"popsize": int(popsize[0])}} if popsize else {})})
    except ValueError:
        raise ConfigError(syntax) from None
    check_levels(levels)
    search = Search(text, levels, *exact_part(exact, "--schedule's exact evaluations"))
    if search.popsize is not None and not search.carry:
        raise ConfigError(f"--schedule {text!r} names a popsize per level (restarted) and for the whole search "
                          "(carried): give one or the other")
    return search


def fidelity_table(searches: list[Search], frames: int, seeds: list[int], out: Path) -> pd.DataFrame:
    """Track the demo sequence (:data:`FIDELITY_RUN`, ``frames`` frames) with each search
    (exact or multi-fidelity), once per search seed of ``seeds`` (the data stay the same),
    one run after the other in a fresh folder; one row per search: mode, label, evaluations
    (cheap, exact), population size, the mean marker error (mm) and search time per frame
    (ms, the foreground apart), both averaged over the seeds, the spread of the error over
    the seeds (sample standard deviation, mm; 0 for one seed), the ratios to the exact run at
    :data:`FIDELITY_REFERENCE` evaluations and the default population size (when run) and
    ``pareto`` (not dominated on time and mean error)."""
    rows = []
    for search in searches:
        errors, times = [], []
        for seed in seeds:
            cfg = compose([*FIDELITY_RUN, *search.overrides(frames, seed)])
            with tempfile.TemporaryDirectory(dir=out) as folder:
                summary = run(cfg, Path(folder))
            errors.append(summary["mean_marker_error_mm"])
            times.append(summary["seconds_per_frame"] * 1e3)
            print(f"fidelity: {search.mode} {search.label}, seed {seed}: {errors[-1]:.1f} mm, "
                  f"{times[-1]:.0f} ms per frame", flush=True)
        rows.append({"mode": search.mode, "evaluations": search.label,
                     "cheap_evaluations": sum(level["evaluations"] for level in search.levels),
                     "exact_evaluations": search.exact,
                     "popsize": search.popsize or strategy_parameters(summary["dof"]).lam,
                     "vertices": summary["vertices"], "seeds": len(seeds),
                     "mean_marker_error_mm": float(np.mean(errors)),
                     "error_sd_mm": float(np.std(errors, ddof=1)) if len(errors) > 1 else 0.0,
                     "ms_per_frame": float(np.mean(times))})
    df = pd.DataFrame(rows)
    reference = [k for k, search in enumerate(searches)
                 if not search.levels and search.exact == FIDELITY_REFERENCE and search.popsize is None]
    if reference:
        df["error_ratio"] = df.mean_marker_error_mm / df.mean_marker_error_mm.iloc[reference[0]]
        df["time_ratio"] = df.ms_per_frame / df.ms_per_frame.iloc[reference[0]]
    df["pareto"] = non_dominated(df[["ms_per_frame", "mean_marker_error_mm"]].to_numpy())
    return df


def machine() -> str:
    """One line about the CPU and the OpenCL device the benchmark ran on."""
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    line = f"{platform.processor() or platform.machine()}, {cpus} CPUs usable"
    try:
        from mmocap.evaluators.opencl import select_device
        dev = select_device(None, 0)
        line += f"; OpenCL: {dev.name.strip()} ({dev.platform.name})"
    except Exception as err:  # no OpenCL: say so, the table simply has no opencl rows
        line += f"; OpenCL unavailable ({err})"
    return line


def write(df: pd.DataFrame, out: Path, name: str, title: str) -> None:
    """CSV and Markdown (with a title and the machine) into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / f"{name}.csv", index=False)
    text = f"# {title}\n\n{machine()}\n\n{df.to_markdown(index=False, floatfmt='.4g')}\n"
    (out / f"{name}.md").write_text(text)
    print(text)


def integer_list(option: str, text: str, low: int, high: int) -> list[int]:
    """The comma-separated integers of ``text`` ("27393,13695"), each in [``low``, ``high``],
    else a ConfigError naming ``option``."""
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        values = []
    if not values:
        raise ConfigError(f"{option} must be comma-separated integers, got {text!r}")
    return [check_number(option, v, low, high, integer=True) for v in values]


def main(argv: list[str], prog: str) -> None:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    parser.add_argument("table", choices=["table1", "table2", "roofline", "all", "fidelity"])
    parser.add_argument("--backends", default=None,
                        help="comma-separated evaluators (default: every one that can run here)")
    parser.add_argument("--vertices", default="27393,20544,13695")
    parser.add_argument("--budgets", default="500,1500,3000,5000")
    parser.add_argument("--cameras", type=int, default=7)
    parser.add_argument("--population", type=int, default=256, help="candidates per timing (table 2)")
    parser.add_argument("--repeats", type=int, default=10, help="timings per backend (table 2), best kept")
    parser.add_argument("--frames", type=int, default=1, help="frames per budget, at least (table 1)")
    parser.add_argument("--seconds", type=float, default=2.0,
                        help=f"more frames (up to {MAX_FRAMES}) while they fit in this time")
    parser.add_argument("--exact", default=f"500,1000,{FIDELITY_REFERENCE},{FIDELITY_REFERENCE}:28",
                        help="exact searches, EVALUATIONS[:POPSIZE][,...] per frame (fidelity)")
    parser.add_argument("--schedule", action="append", default=None,
                        help="a multi-fidelity run, SCALE:VERTICES:EVALUATIONS[:POPSIZE][,...]+EXACT[:POPSIZE] "
                             f"(fidelity; repeat for more; default: {' and '.join(DEFAULT_SCHEDULES)})")
    parser.add_argument("--track-frames", type=int, default=60, help="frames tracked per run (fidelity)")
    parser.add_argument("--seeds", default="0,1,2,3,4",
                        help="search seeds each search is run with, its error and time averaged (fidelity)")
    parser.add_argument("--out", type=Path, default=Path("outputs/tables"))
    parser.add_argument("--prefix", default="", help="prefix of the output file names")
    args = parser.parse_args(argv)
    if args.table == "fidelity":
        searches = parse_exact(args.exact) + [parse_schedule(text) for text in args.schedule or DEFAULT_SCHEDULES]
        frames = check_number("--track-frames", args.track_frames, 1, 10_000, integer=True)
        seeds = integer_list("--seeds", args.seeds, 0, 2**32 - 1)
        args.out.mkdir(parents=True, exist_ok=True)
        table = fidelity_table(searches, frames, seeds, args.out)
        title = (f"Multi-fidelity search against exact CMA-ES (holistic, 39 DOF), S1 walking, realistic, "
                 f"{frames} frames, 4 cameras, 640x480, search seeds {args.seeds} averaged; ratios to exact "
                 f"at {FIDELITY_REFERENCE} evaluations")
        write(table, args.out, f"{args.prefix}fidelity", title)
        figure = args.out / f"{args.prefix}fidelity.png"
        plot_pareto_front(table.assign(seconds_per_frame=table.ms_per_frame / 1e3), figure, colour="mode",
                          note=machine(), title=f"Multi-fidelity against exact search, {frames} frames\n{machine()}")
        print(f"figure: {figure}")
        return
    names = backends() if args.backends is None else [b for b in args.backends.split(",") if b]
    unknown = sorted(set(names) - set(registry.available("evaluator")))
    if unknown:
        parser.error(f"unknown backend(s) {', '.join(unknown)}; installed: "
                     f"{', '.join(sorted(registry.available('evaluator')))}")
    # every argument before anything is built
    levels = integer_list("--vertices", args.vertices, *VERTICES_RANGE)
    budgets = integer_list("--budgets", args.budgets, START_EVALUATIONS + 1, MAX_EVALUATIONS)
    check_number("--cameras", args.cameras, 1, len(CAMERA_RING), integer=True)
    check_number("--population", args.population, 1, 1_000_000, integer=True)
    check_number("--repeats", args.repeats, 1, 1000, integer=True)
    check_number("--frames", args.frames, 1, 1000, integer=True)
    check_number("--seconds", args.seconds, 0, 86_400)
    scenes = {v: Scene(v, args.cameras) for v in levels}
    evaluators = {name: registry.make_evaluator(name) for name in names}
    try:
        naive_us, t2 = {}, None
        if args.table != "table1":
            roofline_only = args.table == "roofline"
            if roofline_only and "opencl" not in evaluators:
                parser.error("roofline needs the opencl backend (--backends opencl)")
            vertices = max(scenes)
            timed = {"opencl": evaluators["opencl"]} if roofline_only else evaluators
            t2 = table2(timed, {vertices: scenes[vertices]} if roofline_only else scenes, args.population,
                        args.repeats)
            if not roofline_only:
                write(t2, args.out, f"{args.prefix}table2", "Time per model-view (Cano Table 2): "
                      "project + count, one 640x480 view, microseconds")
            if "opencl" in timed:
                kernel = t2[(t2.backend == "opencl") & (t2.vertices == vertices)].us_per_model_view.iloc[0]
                write_roofline(vertices, kernel, args.out, args.prefix)
            if roofline_only:
                return
        elif "naive" in evaluators:  # for the extrapolated naive frame times
            t2 = table2({"naive": evaluators["naive"]}, scenes, args.population, args.repeats)
        if "naive" in evaluators:
            naive = t2[t2.backend == "naive"]  # type: ignore[index,union-attr]  # timed just above
            naive_us = dict(zip(naive.vertices, naive.us_per_model_view))
        if args.table in ("table1", "all"):
            t1 = table1(evaluators, scenes, budgets, args.frames, naive_us, args.seconds)
            title = (f"Time per frame (Cano Table 1, Fig. 3): CMA-ES, {args.cameras} cameras, "
                     "milliseconds; naive extrapolated from Table 2")
            write(t1, args.out, f"{args.prefix}table1", title)
            plot_frames_per_second(t1, args.out / f"{args.prefix}fig3.png", note=machine(),
                                   title=f"Frames per second (Cano Fig. 3): CMA-ES, "
                                         f"{args.cameras} cameras\n{machine()}")
            print(f"figure: {args.out / f'{args.prefix}fig3.png'}")
    finally:
        for ev in evaluators.values():
            ev.close()
