"""The optimiser settings presets: settings=paper gives Yeguas Table 3's values to every
algorithm, settings=tuned leaves conf/optimizer/<name>.yaml as it is."""

import pytest
from hydra.utils import instantiate
from omegaconf import OmegaConf

from mmocap import config as mmocap_config
from mmocap.analysis.results import run_key

ALGORITHMS = mmocap_config.options("algorithm")
# Yeguas Table 3 (and Sec. 4: the whole search box, no start point among the random
# population or swarm, no velocity clamp, the APF's survival rate), per optimiser
TABLE3 = {
    "cmaes": {"sigma0": 1.0},
    "de": {
        "popsize": 10,
        "n_placing": 5,
        "n_leading": 5,
        "n_correcting": 5,
        "cr": 0.9,
        "f": 0.5,
        "init_spread": 1.0,
        "include_x0": False,
    },
    "pso": {
        "popsize": 10,
        "phi1": 2.0,
        "phi2": 2.0,
        "w_max": 2.0,
        "w_min": 0.1,
        "v_max": None,
        "init_spread": 1.0,
        "include_x0": False,
    },
    "apf": {"layers": 10, "survival_rate": 0.5, "init_spread": 1.0},
    "psapf": {"layers": 10, "survival_rate": 0.5, "init_spread": 1.0},
}


def composed(settings, algorithm):
    return mmocap_config.compose(["+experiment=table4", f"settings={settings}", f"algorithm={algorithm}"])


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_paper_preset_gives_table3_values_and_keeps_the_rest(algorithm):
    cfg = composed("paper", algorithm)
    name = cfg.optimizer.name
    assert algorithm.startswith(name)
    assert cfg.settings.name == "paper"
    tuned = OmegaConf.to_container(mmocap_config.load(f"optimizer/{name}.yaml"))
    optimizer = OmegaConf.to_container(cfg.optimizer)
    assert set(optimizer) == set(tuned)  # the preset sets values, it adds no key
    assert optimizer == {**tuned, **TABLE3[name]}
    instantiate(cfg.optimizer)


def test_paper_cmaes_first_step_is_the_search_radius():
    cfg = composed("paper", "cmaes-hierarchical")
    assert cfg.optimizer.sigma0 * cfg.strategy.rotation_radius == 0.5  # rad, Table 3's sigma(0)


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_tuned_preset_is_the_optimisers_own_files(algorithm):
    cfg = composed("tuned", algorithm)
    tuned = mmocap_config.load(f"optimizer/{cfg.optimizer.name}.yaml")
    assert OmegaConf.to_container(cfg.optimizer) == OmegaConf.to_container(tuned)
    assert cfg.settings.name == "tuned"


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_the_presets_are_different_runs(algorithm):
    assert run_key(composed("paper", algorithm)) != run_key(composed("tuned", algorithm))


def test_the_preset_also_composes_outside_the_tables():
    cfg = mmocap_config.compose(["+settings=paper", "+algorithm=pso-hierarchical"])
    assert cfg.optimizer.v_max is None
    assert cfg.optimizer.include_x0 is False
