"""The optimiser conformance suite over every installed optimiser, built-in or plugin."""

import pytest

from mmocap import registry
from mmocap.testing.optimizers import OptimizerConformance


class TestInstalledOptimizers(OptimizerConformance):
    @pytest.fixture(params=sorted(registry.available("optimizer")))
    def optimizer_name(self, request):
        return request.param
