"""Where mmocap's Hydra configs live and how to compose them outside a Hydra app.

The configs are the repository's top-level ``conf/`` folder, which the wheel carries as the
package ``mmocap.conf`` (``package-dir`` in ``pyproject.toml``). They are always found as
``pkg://mmocap.conf``, never by a file path, so an installed mmocap finds them as a checkout
does. Users add their own folders with ``--config-dir`` or ``hydra.searchpath``; plugins add
theirs with a Hydra search-path plugin.
"""

from __future__ import annotations

from collections.abc import Iterable
from importlib import resources

from omegaconf import DictConfig, OmegaConf

CONFIG_MODULE = "mmocap.conf"
CONFIG_PATH = f"pkg://{CONFIG_MODULE}"
CONFIG_NAME = "config"
HYDRA_VERSION_BASE = "1.3"


def compose(overrides: Iterable[str] = (), *, return_hydra_config: bool = False) -> DictConfig:
    """The main config with ``overrides`` applied, as ``mmocap`` would run it."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_module

    with initialize_config_module(CONFIG_MODULE, version_base=HYDRA_VERSION_BASE):
        return hydra_compose(CONFIG_NAME, overrides=list(overrides), return_hydra_config=return_hydra_config)


def load(relative_path: str) -> DictConfig:
    """One file of the shipped configs, e.g. ``load("dataset/humaneva.yaml")``."""
    return OmegaConf.load(resources.files(CONFIG_MODULE).joinpath(relative_path).open())  # type: ignore[return-value]  # a mapping in every shipped file


def options(group: str) -> list[str]:
    """The names of the shipped options of a config group (``options("experiment")``)."""
    folder = resources.files(CONFIG_MODULE).joinpath(group)
    return sorted(p.name[: -len(".yaml")] for p in folder.iterdir() if p.name.endswith(".yaml"))
