"""The built-in optimisers and evaluators against the Protocols of :mod:`mmocap.api`.

mypy checks this module strictly (``make typecheck``): each table below types its entries
as their kind's Protocol, so a built-in component whose methods or attributes stop matching
it fails the type check, not only a test at run time. The test makes sure that every
built-in entry point is in a table.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib.metadata import entry_points

import pytest

from mmocap.api import Evaluator, Optimizer
from mmocap.evaluators.auto import auto_evaluator
from mmocap.evaluators.multiprocess import MultiprocessingEvaluator
from mmocap.evaluators.naive import NaiveEvaluator
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.evaluators.opencl import MultiDeviceEvaluator, OpenCLEvaluator
from mmocap.optimizers.apf import AnnealedParticleFilter, PartitionedAnnealedParticleFilter
from mmocap.optimizers.cmaes import CMAES
from mmocap.optimizers.de import DifferentialEvolution
from mmocap.optimizers.pso import ParticleSwarm
from mmocap.registry import GROUPS

OPTIMIZERS: dict[str, type[Optimizer]] = {
    "cmaes": CMAES,
    "de": DifferentialEvolution,
    "pso": ParticleSwarm,
    "apf": AnnealedParticleFilter,
    "psapf": PartitionedAnnealedParticleFilter,
}

EVALUATORS: dict[str, Callable[..., Evaluator]] = {
    "auto": auto_evaluator,
    "naive": NaiveEvaluator,
    "numpy": NumpyEvaluator,
    "opencl": OpenCLEvaluator,
    "multidevice": MultiDeviceEvaluator,
    "multiprocessing": MultiprocessingEvaluator,
}


@pytest.mark.parametrize(("kind", "checked"), [("optimizer", OPTIMIZERS), ("evaluator", EVALUATORS)])
def test_every_builtin_component_is_checked_against_its_protocol(kind: str, checked: dict[str, object]) -> None:
    builtin = {
        ep.name: ep.load()
        for ep in entry_points(group=GROUPS[kind])
        if ep.dist is not None and ep.dist.name == "mmocap"
    }
    assert builtin == checked
