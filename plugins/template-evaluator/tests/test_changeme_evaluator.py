# TEMPLATE: rename the module changeme_evaluator, the class ChangemeChunkedEvaluator, the
# name changeme-chunked and this file (test file names must be unique across plugins).
"""The evaluator counts exactly as mmocap's naive reference (the conformance suite), and its
config repeats its defaults."""

import inspect

from changeme_evaluator.evaluator import ChangemeChunkedEvaluator

from mmocap import config
from mmocap.testing.evaluators import EvaluatorConformance


class TestChangemeChunkedEvaluator(EvaluatorConformance):
    name = "changeme-chunked"
    params = {"chunk": 3}  # the suite's 7 poses then span three chunks


def test_config_repeats_the_constructors_defaults():
    node = config.compose(["evaluator=changeme-chunked"]).evaluator
    defaults = {k: p.default for k, p in inspect.signature(ChangemeChunkedEvaluator).parameters.items()}
    assert {k: v for k, v in node.items() if k not in ("_target_", "name")} == defaults
