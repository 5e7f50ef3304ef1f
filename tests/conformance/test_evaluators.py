"""The evaluator conformance suite over every installed evaluator, built-in or plugin."""
import pytest

from mmocap import registry
from mmocap.testing.evaluators import EvaluatorConformance


class TestInstalledEvaluators(EvaluatorConformance):
    @pytest.fixture(params=sorted(registry.available("evaluator")))
    def evaluator_name(self, request):
        return request.param


needs_opencl = pytest.mark.skipif("opencl" not in registry.available("evaluator"),
                                  reason="the opencl evaluator is not installed")


@needs_opencl
class TestOpenCLWithFourLanes(EvaluatorConformance):
    """The kernel's other vector widths (the default is 8 on a CPU)."""
    name = "opencl"
    params = {"lanes": 4}


@needs_opencl
class TestOpenCLWithSixteenLanes(EvaluatorConformance):
    name = "opencl"
    params = {"lanes": 16}
