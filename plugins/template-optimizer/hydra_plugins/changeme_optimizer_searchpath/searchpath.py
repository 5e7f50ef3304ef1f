# TEMPLATE: rename the class ChangemeOptimizerSearchPath, the provider
# mmocap-changeme-optimizer (the distribution) and the package changeme_optimizer.
"""Hydra search-path plugin: puts this package's ``conf/`` on mmocap's config search path,
so that ``optimizer=changeme-rls`` works once the package is installed (not editable)."""

from hydra.core.config_search_path import ConfigSearchPath
from hydra.plugins.search_path_plugin import SearchPathPlugin


class ChangemeOptimizerSearchPath(SearchPathPlugin):
    """Appends ``pkg://changeme_optimizer.conf`` to Hydra's config search path."""

    def manipulate_search_path(self, search_path: ConfigSearchPath) -> None:
        search_path.append(provider="mmocap-changeme-optimizer", path="pkg://changeme_optimizer.conf")
