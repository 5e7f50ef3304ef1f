"""Every config option composes, and every component in it instantiates."""

import pytest
from hydra.utils import instantiate

from mmocap import config as mmocap_config
from mmocap import registry
from mmocap.api import Evaluator, Optimizer

GROUPS = ["body", "background", "evaluator", "optimizer", "strategy", "partition"]


def options(group):
    return mmocap_config.options(group)


@pytest.mark.parametrize(("group", "option"), [(g, o) for g in GROUPS for o in options(g)])
def test_every_option_instantiates(group, option):
    if group == "evaluator" and (reason := registry.unavailable("evaluator", option)):
        pytest.skip(f"evaluator {option} cannot run here: {reason}")
    cfg = mmocap_config.compose([f"{group}={option}"])
    if group == "partition":
        strategy = instantiate(cfg.strategy)
        assert [list(s) for s in cfg.partition.steps] == strategy.steps
        return
    component = instantiate(cfg[group])
    if group == "background":
        component = component()  # a factory: one model per camera
        assert hasattr(component, "fit")
        assert hasattr(component, "apply")
    if group == "optimizer":
        assert isinstance(component, Optimizer)
    if group == "evaluator":
        assert isinstance(component, Evaluator)


def test_demo_experiment_composes():
    cfg = mmocap_config.compose(["+experiment=demo"], return_hydra_config=True)
    assert cfg.hydra.run.dir == "outputs/demo"
    assert cfg.dataset.frames >= 60
    assert len(cfg.dataset.cameras) == 4
    assert cfg.tracking.evaluations == 1500
    assert cfg.body.dof == 39


def test_fig5_experiment_is_the_cano_recommended_configuration():
    cfg = mmocap_config.compose(["+experiment=fig5"], return_hydra_config=True)
    assert cfg.hydra.run.dir == "outputs/fig5"
    assert cfg.overlays == 2
    assert (cfg.body.vertices, cfg.tracking.evaluations, cfg.evaluator.name) == (27393, 1500, "opencl")
    assert (cfg.dataset.subject, cfg.dataset.action) == ("S1", "walking")


def test_builtins_are_registered_as_entry_points():
    assert {"cmaes"} <= set(registry.available("optimizer"))
    assert {"naive", "numpy"} <= set(registry.available("evaluator"))
    assert all(ep.dist.name == "mmocap" for ep in registry.available("optimizer").values() if ep.name == "cmaes")


def test_search_seed_does_not_change_the_data():
    cfg = mmocap_config.compose(["seed=7"])
    assert cfg.seed == 7
    assert cfg.dataset.seed == 0
