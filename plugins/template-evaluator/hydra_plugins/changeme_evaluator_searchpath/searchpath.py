# TEMPLATE: rename the class ChangemeEvaluatorSearchPath, the provider
# mmocap-changeme-evaluator (the distribution) and the package changeme_evaluator.
"""Hydra search-path plugin: puts this package's ``conf/`` on mmocap's config search path,
so that ``evaluator=changeme-chunked`` works once the package is installed (not editable)."""

from hydra.core.config_search_path import ConfigSearchPath
from hydra.plugins.search_path_plugin import SearchPathPlugin


class ChangemeEvaluatorSearchPath(SearchPathPlugin):
    """Appends ``pkg://changeme_evaluator.conf`` to Hydra's config search path."""

    def manipulate_search_path(self, search_path: ConfigSearchPath) -> None:
        search_path.append(provider="mmocap-changeme-evaluator", path="pkg://changeme_evaluator.conf")
