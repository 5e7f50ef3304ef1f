"""Command line: ``mmocap [hydra overrides]`` tracks; ``mmocap list`` shows plugins;
``mmocap generate [overrides]`` only renders the configured synthetic sequence;
``mmocap export-humaneva SEQUENCE OUT`` writes a sequence folder in the HumanEva-I layout.

Errors the user can fix (:class:`mmocap.errors.MmocapError`) print one line naming the
culprit and exit with status 2, without a traceback.
"""
from __future__ import annotations

import os

# The evaluators batch many small matrix products; BLAS threads only add overhead there
# (and fight with process-level parallelism), so default to one unless the user says.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import hydra  # noqa: E402
from hydra.core.hydra_config import HydraConfig  # noqa: E402
from hydra.errors import InstantiationException  # noqa: E402
from hydra.utils import instantiate  # noqa: E402
from omegaconf import DictConfig  # noqa: E402

from mmocap import registry  # noqa: E402
from mmocap.errors import MmocapError  # noqa: E402

CONFIG_PATH = str(Path(__file__).resolve().parent.parent / "conf")


def _user_error(exc: BaseException) -> MmocapError | None:
    """The MmocapError behind ``exc`` (Hydra wraps errors raised while instantiating)."""
    while exc is not None:
        if isinstance(exc, MmocapError):
            return exc
        exc = exc.__cause__ if isinstance(exc, InstantiationException) else None
    return None


def guarded(job):
    """``job()``; a user error (also one Hydra wraps) becomes one line on stderr and exit 2."""
    try:
        return job()
    except (MmocapError, InstantiationException) as exc:
        err = _user_error(exc)
        if err is None:
            raise
        print(f"mmocap: error: {err}", file=sys.stderr)
        raise SystemExit(2) from None


@hydra.main(config_path=CONFIG_PATH, config_name="config", version_base="1.3")
def track_app(cfg: DictConfig) -> None:
    from mmocap.pipeline import run

    output_dir = Path(HydraConfig.get().runtime.output_dir)
    summary = guarded(lambda: run(cfg, output_dir))
    print(f"{summary['subject']} {summary['action']}: {summary['optimizer']} {summary['strategy']} "
          f"{summary['dof']} DOF, {summary['evaluations_per_frame']} evaluations/frame, "
          f"{summary['frames']} frames: mean marker error {summary['mean_marker_error_mm']:.1f} mm, "
          f"{summary['seconds_per_frame']:.2f} s/frame ({summary['backend']} backend) -> {output_dir}")


@hydra.main(config_path=CONFIG_PATH, config_name="config", version_base="1.3")
def generate_app(cfg: DictConfig) -> None:
    sequence = guarded(lambda: instantiate(cfg.dataset).open(progress=cfg.progress))
    print(f"sequence ready: {sequence.root} ({sequence.n_frames} frames, "
          f"cameras {', '.join(c.name for c in sequence.cameras)})")


def export_humaneva(args: list[str]) -> None:
    from mmocap.data.humaneva import TRIALS, export

    parser = argparse.ArgumentParser(
        prog="mmocap export-humaneva",
        description="Write a synthetic sequence folder in the HumanEva-I layout (S*/Calibration_Data, "
                    "Image_Data, Sync_Data, Mocap_Data at 120 Hz, Background).")
    parser.add_argument("sequence", help="a sequence folder (the one holding sequence.json)")
    parser.add_argument("out", help="the HumanEva-I folder to write into")
    parser.add_argument("--trial", type=int, default=1, choices=TRIALS)
    parser.add_argument("--images", choices=("avi", "png"), default="avi",
                        help="lossless FFV1 videos (default) or folders of numbered PNG frames")
    parser.add_argument("--mocap-lead", type=int, default=4,
                        help="mocap frames, all markers missing, before the video starts (default 4)")
    options = parser.parse_args(args)
    out = guarded(lambda: export(options.sequence, options.out, trial=options.trial, images=options.images,
                                  mocap_lead=options.mocap_lead))
    print(f"HumanEva-I layout written to {out}")


def main() -> None:
    args = sys.argv[1:]
    if args and args[0] == "list":
        print(registry.describe())
        return
    if args and args[0] == "generate":
        sys.argv = [sys.argv[0]] + args[1:]
        generate_app()
        return
    if args and args[0] == "export-humaneva":
        export_humaneva(args[1:])
        return
    track_app()


if __name__ == "__main__":
    main()
