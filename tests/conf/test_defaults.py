"""One owner for every default: the code's constructor signatures.

The shipped YAML of a component lists its parameters, so that they can be seen
(``mmocap track --cfg job``) and overridden, with the values of the code's defaults. This
test fails when the two disagree, or when a YAML key is not a parameter at all. Only the
exceptions below may differ, each for the reason given.
"""

import inspect

import pytest
from hydra.utils import get_object
from omegaconf import OmegaConf

from mmocap import config, registry

GROUPS = ("optimizer", "evaluator", "background", "strategy", "body", "dataset")

# (group, option) -> {key: why the option sets its own value}
PRESETS = {
    ("background", "knn"): {
        "method": "the option selects OpenCV's KNN subtractor",
        "threshold": "KNN's dist2Threshold (OpenCV's default 400) is on another scale than MOG2's varThreshold",
    },
    ("dataset", "humaneva"): {
        "marker_map": "HumanEva-I's mocap labels: the reader's default (None) reads them from this file"
    },
}


def component(node):
    """The callable a config node builds: the registered class for registry targets."""
    target = node["_target_"]
    if target.startswith("mmocap.registry.make_"):
        return registry.load(target.rpartition("make_")[2], node["name"])
    return get_object(target)


def plain(value):
    """Tuples (as code defaults are written) as lists (as YAML reads them), recursively."""
    return [plain(v) for v in value] if isinstance(value, (tuple, list)) else value


def option_values():
    for group in GROUPS:
        for option in config.options(group):
            node = OmegaConf.to_container(config.load(f"{group}/{option}.yaml"), resolve=False)
            if "_target_" in node:
                yield group, option, node
    main = OmegaConf.to_container(config.load("config.yaml"), resolve=False)
    for key, node in main.items():  # components configured in the main config itself
        if isinstance(node, dict) and "_target_" in node:
            yield "config", key, node


@pytest.mark.parametrize(
    ("group", "option", "node"), list(option_values()), ids=[f"{g}/{o}" for g, o, _ in option_values()]
)
def test_yaml_values_are_the_codes_defaults(group, option, node):
    parameters = inspect.signature(component(node)).parameters
    presets = PRESETS.get((group, option), {})
    for key, value in node.items():
        if key.startswith("_") or (key == "name" and node["_target_"].startswith("mmocap.registry")):
            continue
        assert key in parameters, f"{group}/{option}.yaml: {key} is not a parameter of {node['_target_']}"
        if isinstance(value, str) and (value.startswith("${") or value == "???") or key in presets:
            continue  # wiring to another config value, a value the user must give, or a documented preset
        default = parameters[key].default
        assert default is not inspect.Parameter.empty, f"{group}/{option}.yaml: {key} has no default in code"
        default = plain(default)
        assert value == default, f"{group}/{option}.yaml: {key} is {value!r}, the code's default {default!r}"


def test_a_disagreement_is_caught():
    node = OmegaConf.to_container(config.load("optimizer/de.yaml"))
    node["cr"] = 0.123
    with pytest.raises(AssertionError, match="cr is 0.123"):
        test_yaml_values_are_the_codes_defaults("optimizer", "de", node)
