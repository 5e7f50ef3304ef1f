"""The evaluator conformance suite over every installed evaluator, built-in or plugin."""
import pytest

from mmocap import registry
from mmocap.testing.evaluators import EvaluatorConformance


class TestInstalledEvaluators(EvaluatorConformance):
    @pytest.fixture(params=sorted(registry.available("evaluator")))
    def evaluator_name(self, request):
        return request.param
