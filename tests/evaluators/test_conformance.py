"""The evaluator conformance suite over every installed evaluator, built-in or plugin."""

import pytest

from mmocap import registry
from mmocap.testing.evaluators import EvaluatorConformance


def installed() -> list:
    """Every installed evaluator; one that cannot run here is skipped, saying why."""
    return [
        pytest.param(name, marks=pytest.mark.skip(reason=f"{name} unavailable: {reason}"))
        if (reason := registry.unavailable("evaluator", name))
        else name
        for name in sorted(registry.available("evaluator"))
    ]


class TestInstalledEvaluators(EvaluatorConformance):
    @pytest.fixture(params=installed())
    def evaluator_name(self, request):
        return request.param


needs_opencl = pytest.mark.skipif(
    registry.unavailable("evaluator", "opencl") is not None,
    reason="the opencl evaluator is not installed or cannot run here",
)


@needs_opencl
class TestOpenCLWithFourLanes(EvaluatorConformance):
    """The kernel's other vector widths (the default is 8 on a CPU)."""

    name = "opencl"
    params = {"lanes": 4}


@needs_opencl
class TestOpenCLWithSixteenLanes(EvaluatorConformance):
    name = "opencl"
    params = {"lanes": 16}
