"""The evaluators the benchmark times by default (mmocap.bench.backends): found through the
registry, the built-in ones first in a fixed order, then the plugins'."""

from types import SimpleNamespace

import pytest

from mmocap import registry
from mmocap.bench.backends import BUILT_IN, backends
from mmocap.evaluators.numpy_backend import NumpyEvaluator


def test_a_plugins_evaluator_is_timed_after_the_built_in_ones_whose_order_stays(monkeypatch):
    real = registry.available
    plugin = SimpleNamespace(
        name="aaa-plugin", value="aaa:Evaluator", dist=SimpleNamespace(name="aaa"), load=lambda: NumpyEvaluator
    )
    monkeypatch.setattr(
        registry, "available", lambda kind: {**real(kind), **({"aaa-plugin": plugin} if kind == "evaluator" else {})}
    )
    names = backends()
    built_in = [name for name in names if getattr(registry.available("evaluator")[name].dist, "name", None) == BUILT_IN]
    assert names[: len(built_in)] == built_in == sorted(built_in, key=lambda name: (name != "naive", name))
    assert built_in[0] == "naive"
    assert {"numpy", "multiprocessing"} <= set(built_in)
    plugins = names[len(built_in) :]
    assert "aaa-plugin" in plugins
    assert plugins == sorted(plugins)


def test_the_templates_evaluator_is_timed_where_it_is_installed():
    pytest.importorskip("changeme_evaluator")
    assert "changeme-chunked" in backends()
