"""Stage "plausibility": warnings when the fit says the model explains the foreground poorly.

A wrong foreground (a lossy video that the background model takes for motion, a background
plate that no longer fits the scene, a calibration that does not match the images) still
gives a pose and a body: the search finds the best fit to whatever the masks hold. The fit
tells it apart from a correct track in three ways, each checked by :class:`Plausibility`:

- the fitness (0 = the model covers the foreground exactly, 1 = not at all): the start's and
  the run's mean over the frames, against ``max_fitness``;
- the body the automatic start ended with, against the heights and girths a person has
  (``min_height_mm``-``max_height_mm``, ``min_girth``-``max_girth``);
- that body's height against the visual hull's of the first frame, which measures the
  foreground itself, within ``hull_tolerance_mm``.

Each check that fails gives one :class:`~mmocap.errors.MmocapWarning` line naming the figure,
the threshold and what to check, and a finding (:meth:`Plausibility.findings`) that the run
records in ``summary.json`` under ``plausibility``. The thresholds and the measurements they
rest on are in ``conf/config.yaml`` (``plausibility:``) and docs/troubleshooting.md.
"""

from __future__ import annotations

import warnings

from mmocap.body.mesh import GIRTH_RANGE, HEIGHT_RANGE_MM
from mmocap.errors import MmocapWarning
from mmocap.validate import check_number

#: what every plausibility warning tells the user to check
WHAT_TO_CHECK = (
    "check the foreground (overlays/, video=true, `mmocap check-recording`), the background "
    "method (background=) and the calibration"
)
#: what a correct fit gives (measured: docs/troubleshooting.md)
CORRECT_FITNESS = "0.05-0.11 on synthetic data, about 0.13 on a real recording"


class Plausibility:
    """Hydra component (``plausibility:`` in ``conf/config.yaml``): see the module docstring.

    Args:
        max_fitness: the start's fitness, or the run's mean fitness, above this is a warning.
        min_height_mm, max_height_mm: the standing heights (mm) a person has.
        min_girth, max_girth: the girths a person has (1 = the base mesh).
        hull_tolerance_mm: the body's height may differ from the visual hull's by this, mm.
    """

    def __init__(
        self,
        max_fitness: float = 0.2,
        min_height_mm: float = 1400.0,
        max_height_mm: float = 2000.0,
        min_girth: float = 0.7,
        max_girth: float = 1.5,
        hull_tolerance_mm: float = 200.0,
    ):
        self.max_fitness = check_number("plausibility.max_fitness", max_fitness, 0, 1, low_open=True)
        self.min_height_mm = check_number("plausibility.min_height_mm", min_height_mm, *HEIGHT_RANGE_MM)
        self.max_height_mm = check_number(
            "plausibility.max_height_mm", max_height_mm, min_height_mm, HEIGHT_RANGE_MM[1]
        )
        self.min_girth = check_number("plausibility.min_girth", min_girth, *GIRTH_RANGE)
        self.max_girth = check_number("plausibility.max_girth", max_girth, min_girth, GIRTH_RANGE[1])
        self.hull_tolerance_mm = check_number("plausibility.hull_tolerance_mm", hull_tolerance_mm, 0, 5000)
        self._findings: list[dict] = []

    def findings(self) -> list[dict]:
        """The checks that failed, in order, each ``{"check", "value", "limit", "message"}``
        (JSON types; ``value`` in the check's unit, ``limit`` a number or ``[low, high]``)."""
        return list(self._findings)

    def check_start(self, start) -> None:
        """Warn about the automatic start's result ``start`` (a
        :class:`~mmocap.stages.initialisation.StartResult`): its fitness, its body's height
        (mm) and girth, and that height against the visual hull's. The fitness is the
        silhouettes' alone, which the threshold was measured on, with keypoints or not."""
        fitness, body = start.silhouette_fitness, start.body.subject
        if fitness > self.max_fitness:
            self._warn(
                "start_fitness",
                fitness,
                self.max_fitness,
                f"the automatic start's fitness is {fitness:.3f}, above plausibility.max_fitness="
                f"{self.max_fitness:g} (a correct fit: {CORRECT_FITNESS}): the model explains the foreground poorly",
            )
        if not self.min_height_mm <= body.height_mm <= self.max_height_mm:
            self._warn(
                "body_height_mm",
                body.height_mm,
                [self.min_height_mm, self.max_height_mm],
                f"the automatic start's body is {body.height_mm:.0f} mm tall, outside plausibility."
                f"min_height_mm-max_height_mm={self.min_height_mm:g}-{self.max_height_mm:g} mm",
            )
        if not self.min_girth <= body.girth <= self.max_girth:
            self._warn(
                "body_girth",
                body.girth,
                [self.min_girth, self.max_girth],
                f"the automatic start's body has girth {body.girth:.2f}, outside plausibility."
                f"min_girth-max_girth={self.min_girth:g}-{self.max_girth:g}",
            )
        apart = abs(body.height_mm - start.height_mm)
        if apart > self.hull_tolerance_mm:
            self._warn(
                "height_against_hull_mm",
                apart,
                self.hull_tolerance_mm,
                f"the body is {body.height_mm:.0f} mm tall but the first frame's visual hull "
                f"{start.height_mm:.0f} mm, {apart:.0f} mm apart, more than plausibility.hull_tolerance_mm="
                f"{self.hull_tolerance_mm:g}; check body.height_mm if given",
            )

    def check_run(self, mean_fitness: float) -> None:
        """Warn if the run's mean fitness over its frames (NaN: not known) is above
        ``max_fitness``."""
        if mean_fitness > self.max_fitness:
            self._warn(
                "mean_fitness",
                mean_fitness,
                self.max_fitness,
                f"the run's mean fitness is {mean_fitness:.3f}, above plausibility.max_fitness="
                f"{self.max_fitness:g} (a correct track: {CORRECT_FITNESS}): the model explains the foreground poorly",
            )

    def _warn(self, check: str, value: float, limit, message: str) -> None:
        """One warning line: ``message``, then what to check; recorded as a finding."""
        message = f"{message}; {WHAT_TO_CHECK}"
        self._findings.append({"check": check, "value": round(float(value), 4), "limit": limit, "message": message})
        warnings.warn(message, MmocapWarning, stacklevel=3)
