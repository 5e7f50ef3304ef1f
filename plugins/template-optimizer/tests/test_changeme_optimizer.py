# TEMPLATE: rename the module changeme_optimizer, the class ChangemeRandomLocalSearch, the
# name changeme-rls and this file (test file names must be unique across plugins).
"""The optimiser passes mmocap's conformance suite, and its config repeats its defaults."""

import inspect

from changeme_optimizer.optimizer import ChangemeRandomLocalSearch

from mmocap import config
from mmocap.testing.optimizers import OptimizerConformance


class TestChangemeRandomLocalSearch(OptimizerConformance):
    name = "changeme-rls"


def test_config_repeats_the_constructors_defaults():
    node = config.compose(["optimizer=changeme-rls"]).optimizer
    defaults = {k: p.default for k, p in inspect.signature(ChangemeRandomLocalSearch).parameters.items()}
    assert {k: v for k, v in node.items() if k not in ("_target_", "name")} == defaults
