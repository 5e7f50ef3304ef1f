"""Which evaluators the benchmark times by default: the installed ones, found through the
registry (a plugin's evaluator included), that can run here."""

from __future__ import annotations

from mmocap import registry

#: the distribution that registers the built-in evaluators
BUILT_IN = "mmocap"


def backends() -> list[str]:
    """The default ``--backends``: every installed evaluator that can run here but ``auto``
    (which runs one of them): ``naive`` (the speed-ups' reference) first, then the other
    built-in ones, then the plugins' (such as the template's ``changeme-chunked``), each
    group by name."""

    def order(item) -> tuple:
        name, entry_point = item
        return name != "naive", getattr(entry_point.dist, "name", None) != BUILT_IN, name

    names = [name for name, _ in sorted(registry.available("evaluator").items(), key=order)]
    return [name for name in names if name != "auto" and registry.unavailable("evaluator", name) is None]
