"""Hydra search-path plugin: puts this package's ``conf/`` (``optimizer/pycma.yaml``) on
mmocap's config search path, so that ``optimizer=pycma`` works once the package is installed."""

from hydra.core.config_search_path import ConfigSearchPath
from hydra.plugins.search_path_plugin import SearchPathPlugin


class MmocapPycmaSearchPath(SearchPathPlugin):
    """Appends ``pkg://mmocap_pycma.conf`` to Hydra's config search path."""

    def manipulate_search_path(self, search_path: ConfigSearchPath) -> None:
        search_path.append(provider="mmocap-pycma", path="pkg://mmocap_pycma.conf")
