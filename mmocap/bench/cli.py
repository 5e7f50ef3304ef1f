"""``mmocap bench``: the evaluator benchmark for this machine.

- ``table2``: Cano Table 2, time per model-view per backend and vertex level
  (:func:`mmocap.bench.tables.table2`), and the kernel's roofline beside it when the opencl
  backend is timed;
- ``table1``: Cano Table 1 and Fig. 3, time per CMA-ES frame per backend, vertex level and
  budget, and the host's share of it (:func:`mmocap.bench.tables.table1`);
- ``roofline``: the silhouette kernel's time per model-view at the largest vertex level
  beside the floor of this device's measured rates (:mod:`mmocap.bench.roofline`), and where
  its time goes, part by part (:mod:`mmocap.bench.parts`);
- ``keypoints``: the keypoint term's cost, the time per evaluation with the hybrid fitness
  against the silhouettes alone at the demo's and Cano's workloads
  (:mod:`mmocap.bench.keypoints`), by default on the opencl backend;
- ``all``: ``table2`` then ``table1``, and ``keypoints`` when the opencl backend is timed;
- ``fidelity``: multi-fidelity against exact search on the demo sequence
  (:mod:`mmocap.bench.fidelity`); ``fidelity-cano``: the same at Cano's workload (7 cameras,
  27393 vertices);
- ``fullhd``: a full-HD recording tracked from nothing at full resolution and at reduced
  working scales, with where the foreground's time goes (:mod:`mmocap.bench.fullhd`).

The vertex levels and budgets default to the Cano paper's, as the paper scale of the sweeps
gives them (``scale.meshes`` and ``scale.cano_budgets`` of ``conf/scale/paper.yaml``). The
backends default to every installed evaluator that can run here
(:func:`mmocap.bench.backends.backends`), on the synthetic scene
(:class:`mmocap.testing.scene.Scene`).

Usage::

    mmocap bench table2
    mmocap bench table1 --vertices 13695 --budgets 500,1500
    mmocap bench roofline --backends opencl --vertices 27393
    mmocap bench keypoints --workloads 4:13695,7:27393
    mmocap bench all --vertices 27393 --budgets 500,1500 --prefix bench_
    mmocap bench fidelity --exact 500,1000,1500 --schedule 0.25:3000:1200+300
    mmocap bench fidelity-cano --exact 1500 --seeds 0,1,2 --track-frames 30
    mmocap bench fullhd --scales 1,0.5,0.333 --track-frames 20
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from mmocap import registry
from mmocap.analysis.figures import plot_frames_per_second, plot_pareto_front
from mmocap.bench import fidelity, fullhd, keypoints, parts, roofline
from mmocap.bench.backends import backends
from mmocap.bench.output import TableWriter, update_bench_page
from mmocap.bench.tables import MAX_FRAMES, table1, table2
from mmocap.body.model import VERTICES_RANGE
from mmocap.config import load
from mmocap.data.synthetic import CAMERA_RING
from mmocap.errors import ConfigError
from mmocap.report.results_page import machine
from mmocap.stages.tracking import MAX_EVALUATIONS, START_EVALUATIONS
from mmocap.testing.scene import Scene
from mmocap.validate import check_number
from mmocap.video import CRF_RANGE

#: frames tracked per run of ``fidelity`` unless ``--track-frames`` says (the demo sequence's)
FIDELITY_FRAMES = 60

#: the tables each subcommand makes, by name: its sections of a ``--page``
TABLES = {
    "table1": ("table1",),
    "table2": ("table2", "roofline", "kernel_parts"),
    "roofline": ("roofline", "kernel_parts"),
    "keypoints": ("keypoints",),
    "all": ("table2", "roofline", "kernel_parts", "table1", "keypoints"),
    "fidelity": ("fidelity",),
    "fidelity-cano": ("fidelity_cano",),
    "fullhd": ("fullhd", "fullhd_foreground"),
}


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


def build_parser(prog: str) -> argparse.ArgumentParser:
    """The command's arguments; the levels and budgets default to the paper scale's."""
    paper = load("scale/paper.yaml").scale
    parser = argparse.ArgumentParser(
        prog=prog, description="Evaluator benchmark: the Cano paper's Tables 1 and 2 (and Fig. 3) for this machine."
    )
    parser.add_argument("table", choices=list(TABLES))
    parser.add_argument(
        "--backends",
        default=None,
        help="comma-separated evaluators (default: every one that can run here; keypoints: opencl)",
    )
    parser.add_argument("--vertices", default=str(paper.meshes))
    parser.add_argument("--budgets", default=str(paper.cano_budgets))
    parser.add_argument("--cameras", type=int, default=7)
    parser.add_argument(
        "--population", type=int, default=256, help="candidates per timing (table 2; keypoints beside CMA-ES's)"
    )
    parser.add_argument("--repeats", type=int, default=10, help="timings per backend (table 2, keypoints), best kept")
    parser.add_argument(
        "--workloads",
        default=keypoints.WORKLOADS,
        help="CAMERAS:VERTICES[,...] timed with the keypoint term off and on (keypoints, all)",
    )
    parser.add_argument("--frames", type=int, default=1, help="frames per budget, at least (table 1)")
    parser.add_argument(
        "--seconds", type=float, default=2.0, help=f"more frames (up to {MAX_FRAMES}) while they fit in this time"
    )
    parser.add_argument(
        "--exact",
        default=f"500,1000,{fidelity.FIDELITY_REFERENCE},{fidelity.FIDELITY_REFERENCE}:28",
        help="exact searches, EVALUATIONS[:POPSIZE][,...] per frame (fidelity)",
    )
    parser.add_argument(
        "--schedule",
        action="append",
        default=None,
        help="a multi-fidelity run, SCALE:VERTICES:EVALUATIONS[:POPSIZE][,...]+EXACT[:POPSIZE] "
        f"(fidelity; repeat for more; default: {' and '.join(fidelity.DEFAULT_SCHEDULES)})",
    )
    parser.add_argument(
        "--track-frames",
        type=int,
        default=None,
        help=f"frames tracked per run (fidelity: {FIDELITY_FRAMES}; fullhd: {fullhd.FULLHD_FRAMES}, as many rendered)",
    )
    parser.add_argument(
        "--scales",
        default=fullhd.DEFAULT_SCALES,
        help="working scales (dataset.scale) tracked at, 1 among them (fullhd)",
    )
    parser.add_argument("--width", type=int, default=fullhd.FULLHD_WIDTH, help="image width, px (fullhd)")
    parser.add_argument("--height", type=int, default=fullhd.FULLHD_HEIGHT, help="image height, px (fullhd)")
    parser.add_argument(
        "--crf", type=int, default=fullhd.FULLHD_CRF, help="the recording's H.264 quality, 0 lossless (fullhd)"
    )
    parser.add_argument(
        "--seeds",
        default="0,1,2,3,4",
        help="search seeds each search is run with, its error and time averaged (fidelity)",
    )
    parser.add_argument("--out", type=Path, default=Path("outputs/tables"))
    parser.add_argument("--prefix", default="", help="prefix of the output file names")
    parser.add_argument(
        "--page",
        type=Path,
        default=None,
        help="also put the tables into this Markdown page, in place of its sections of the "
        "tables this subcommand makes, stamped with the date and machine (make bench: "
        "docs/results/bench.md)",
    )
    return parser


def main(argv: list[str], prog: str) -> None:
    """``mmocap bench ARGUMENTS`` (``argv``): the subcommand's tables, and their page."""
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    tables = TableWriter(args.out, args.prefix)
    if args.table in fidelity.WORKLOADS:
        fidelity_command(args, tables)
    elif args.table == "fullhd":
        fullhd_command(args, tables)
    elif args.table == "keypoints":
        keypoints_command(args, tables, parser)
    else:
        timings_command(args, tables, parser)
    if args.page is not None:
        update_bench_page(args.page, tables.sections, TABLES[args.table])


def fidelity_command(args: argparse.Namespace, tables: TableWriter) -> None:
    """``fidelity`` or ``fidelity-cano``: the searches of ``--exact`` and ``--schedule`` at
    the subcommand's workload, table and figure."""
    workload = fidelity.WORKLOADS[args.table]
    searches = fidelity.parse_exact(args.exact) + [
        fidelity.parse_schedule(text) for text in args.schedule or fidelity.DEFAULT_SCHEDULES
    ]
    frames = check_number(
        "--track-frames", FIDELITY_FRAMES if args.track_frames is None else args.track_frames, 1, 10_000, integer=True
    )
    seeds = integer_list("--seeds", args.seeds, 0, 2**32 - 1)
    args.out.mkdir(parents=True, exist_ok=True)
    table = fidelity.fidelity_table(searches, frames, seeds, args.out, workload)
    title = (
        f"Multi-fidelity search against exact CMA-ES (holistic, 39 DOF), S1 walking, realistic, "
        f"{frames} frames, {workload.description}, search seeds {args.seeds} averaged; ratios to exact "
        f"at {fidelity.FIDELITY_REFERENCE} evaluations"
    )
    tables.write(table, workload.table, title)
    figure = tables.path(workload.table, ".png")
    plot_pareto_front(
        table.assign(seconds_per_frame=table.ms_per_frame / 1e3),
        figure,
        colour="mode",
        note=machine(),
        title=f"Multi-fidelity against exact search, {frames} frames, {workload.description}\n{machine()}",
    )
    print(f"figure: {figure}")


def fullhd_command(args: argparse.Namespace, tables: TableWriter) -> None:
    """``fullhd``: the full-HD recording tracked at each of ``--scales``, and the profile of
    its foreground (:mod:`mmocap.bench.fullhd`)."""
    scales = fullhd.parse_scales(args.scales)
    width = check_number("--width", args.width, 64, 8192, integer=True)
    height = check_number("--height", args.height, 64, 8192, integer=True)
    frames = check_number(
        "--track-frames",
        fullhd.FULLHD_FRAMES if args.track_frames is None else args.track_frames,
        1,
        10_000,
        integer=True,
    )
    crf = check_number("--crf", args.crf, *CRF_RANGE, integer=True)
    args.out.mkdir(parents=True, exist_ok=True)
    runs, profile = fullhd.fullhd_tables(scales, width, height, frames, fullhd.FULLHD_SEED, args.out, crf)
    coding = "lossless" if crf == 0 else f"H.264 crf {crf}"
    what = f"S1 walking, 4 cameras, {width}x{height}, {frames} frames, {coding} recording"
    tables.write(
        runs,
        "fullhd",
        f"Full HD tracked from nothing ({what}): automatic start, holistic CMA-ES 1500 evaluations, "
        f"at each working scale; ratios to scale 1; goal: at most {fullhd.GOAL_FRAME_SECONDS:g} s per frame "
        f"(foreground and search) at {fullhd.GOAL_ERROR_RATIO:g}x the error, start within "
        f"{fullhd.GOAL_START_SECONDS:g} s",
    )
    tables.write(
        profile,
        "fullhd_foreground",
        f"Where the foreground's time goes ({what}), s per frame, 4 cameras, at each working scale",
    )


def keypoints_command(args: argparse.Namespace, tables: TableWriter, parser: argparse.ArgumentParser) -> None:
    """``keypoints``: the keypoint term's cost on ``--backends`` (default: opencl)."""
    names = chosen_backends(args.backends, parser, default=["opencl"])
    workloads = keypoints.parse_workloads(args.workloads)
    check_number("--population", args.population, 1, 1_000_000, integer=True)
    check_number("--repeats", args.repeats, 1, 1000, integer=True)
    evaluators = {name: registry.make_evaluator(name) for name in names}
    try:
        write_keypoints(args, tables, evaluators, workloads)
    finally:
        for ev in evaluators.values():
            ev.close()


def write_keypoints(
    args: argparse.Namespace, tables: TableWriter, evaluators: dict, workloads: list[tuple[int, int]]
) -> None:
    """The keypoint term's cost per evaluation, off and on, at each of ``workloads``."""
    table = keypoints.keypoint_table(evaluators, workloads, args.population, args.repeats)
    tables.write(
        table,
        "keypoints",
        "Cost of the keypoint term: time per evaluation with the hybrid fitness (17 model points, weight 1) "
        "against the silhouettes alone, 640x480, microseconds, at the population of CMA-ES and of Table 2; "
        f"goal: ratio at most {keypoints.GOAL_RATIO:g}",
    )


def chosen_backends(text: str | None, parser: argparse.ArgumentParser, default: list[str] | None = None) -> list[str]:
    """``--backends`` (else ``default``, else :func:`backends`); an unknown name ends the command."""
    names = (default or backends()) if text is None else [b for b in text.split(",") if b]
    unknown = sorted(set(names) - set(registry.available("evaluator")))
    if unknown:
        parser.error(
            f"unknown backend(s) {', '.join(unknown)}; installed: {', '.join(sorted(registry.available('evaluator')))}"
        )
    return names


def timings_command(args: argparse.Namespace, tables: TableWriter, parser: argparse.ArgumentParser) -> None:
    """``table1``, ``table2``, ``roofline`` and ``all``: every argument checked before anything
    is built, then the scenes and evaluators, closed at the end."""
    names = chosen_backends(args.backends, parser)
    levels = integer_list("--vertices", args.vertices, *VERTICES_RANGE)
    budgets = integer_list("--budgets", args.budgets, START_EVALUATIONS + 1, MAX_EVALUATIONS)
    check_number("--cameras", args.cameras, 1, len(CAMERA_RING), integer=True)
    check_number("--population", args.population, 1, 1_000_000, integer=True)
    check_number("--repeats", args.repeats, 1, 1000, integer=True)
    check_number("--frames", args.frames, 1, 1000, integer=True)
    check_number("--seconds", args.seconds, 0, 86_400)
    workloads = keypoints.parse_workloads(args.workloads) if args.table == "all" else []
    if args.table == "roofline" and "opencl" not in names:
        parser.error("roofline needs the opencl backend (--backends opencl)")
    scenes = {v: Scene(v, args.cameras) for v in levels}
    evaluators = {name: registry.make_evaluator(name) for name in names}
    try:
        if args.table == "roofline":
            write_roofline(args, tables, {"opencl": evaluators["opencl"]}, scenes)
        elif args.table == "table2":
            write_table2(args, tables, evaluators, scenes)
        elif args.table == "table1":
            write_table1(args, tables, evaluators, scenes, budgets)
        else:
            write_table1(args, tables, evaluators, scenes, budgets, write_table2(args, tables, evaluators, scenes))
            if "opencl" in evaluators:
                write_keypoints(args, tables, {"opencl": evaluators["opencl"]}, workloads)
    finally:
        for ev in evaluators.values():
            ev.close()


def write_roofline(
    args: argparse.Namespace, tables: TableWriter, evaluators: dict, scenes: dict, times: pd.DataFrame | None = None
) -> None:
    """The roofline at the largest vertex level, beside the opencl kernel's Table 2 time
    there (from ``times``, Table 2, else timed now), and the kernel's parts there."""
    vertices = max(scenes)
    if times is None:
        times = table2(evaluators, {vertices: scenes[vertices]}, args.population, args.repeats)
    kernel = times[(times.backend == "opencl") & (times.vertices == vertices)].us_per_model_view.iloc[0]
    tables.write(
        roofline.table(vertices, kernel),
        "roofline",
        f"Roofline of the silhouette kernel: one 640x480 model-view at {vertices} vertices, microseconds",
    )
    tables.write(
        parts.parts_table(lambda: registry.make_evaluator("opencl"), scenes[vertices], args.population, args.repeats),
        "kernel_parts",
        f"Where the silhouette kernel's time goes: built to stop after each part, one 640x480 model-view at "
        f"{vertices} vertices, {args.population} candidates per call, microseconds",
    )


def write_table2(args: argparse.Namespace, tables: TableWriter, evaluators: dict, scenes: dict) -> pd.DataFrame:
    """Table 2 of every backend and vertex level, and the roofline when opencl is timed;
    returns Table 2."""
    times = table2(evaluators, scenes, args.population, args.repeats)
    tables.write(
        times, "table2", "Time per model-view (Cano Table 2): project and count, one 640x480 view, microseconds"
    )
    if "opencl" in evaluators:
        write_roofline(args, tables, evaluators, scenes, times)
    return times


def write_table1(
    args: argparse.Namespace,
    tables: TableWriter,
    evaluators: dict,
    scenes: dict,
    budgets: list[int],
    times: pd.DataFrame | None = None,
) -> None:
    """Table 1 and Fig. 3; naive's frame times extrapolated from its Table 2 ``times`` (when
    not given, naive alone is timed for them)."""
    naive_us = {}
    if "naive" in evaluators:
        if times is None:
            times = table2({"naive": evaluators["naive"]}, scenes, args.population, args.repeats)
        naive = times[times.backend == "naive"]
        naive_us = dict(zip(naive.vertices, naive.us_per_model_view))
    t1 = table1(evaluators, scenes, budgets, args.frames, naive_us, args.seconds)
    title = (
        f"Time per frame (Cano Table 1, Fig. 3): CMA-ES, {args.cameras} cameras, "
        "milliseconds; naive extrapolated from Table 2"
    )
    tables.write(t1, "table1", title)
    figure = tables.path("fig3", ".png")
    plot_frames_per_second(
        t1,
        figure,
        note=machine(),
        title=f"Frames per second (Cano Fig. 3): CMA-ES, {args.cameras} cameras\n{machine()}",
    )
    print(f"figure: {figure}")
