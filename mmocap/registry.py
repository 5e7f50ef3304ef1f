"""Discovery of optimisers, evaluators and keypoint detectors through entry points.

Built-in components are registered in mmocap's own ``pyproject.toml`` under the groups
``mmocap.optimizers``, ``mmocap.evaluators`` and ``mmocap.detectors``, exactly as a third-party plugin registers
its own; Hydra configs build them with ``_target_: mmocap.registry.make_optimizer``.

A registered class may say that it cannot run here with a classmethod
``unavailable() -> str | None`` (a missing library or device, and what to install; None
when it can run): ``mmocap list`` shows the reason, and building it is a ConfigError that
gives it. A class without that method is taken to be available.

What is built is typed as the Protocol of its kind (:class:`mmocap.api.Optimizer`,
:class:`mmocap.api.Evaluator`, :class:`mmocap.api.Detector`): a plugin is not checked against it statically, the
built-in components are (``tests/test_api_types.py``).
"""

from __future__ import annotations

from importlib.metadata import EntryPoint, entry_points
from typing import Any, cast

from mmocap.api import Detector, Evaluator, Optimizer
from mmocap.errors import ConfigError

GROUPS = {"optimizer": "mmocap.optimizers", "evaluator": "mmocap.evaluators", "detector": "mmocap.detectors"}


def available(kind: str) -> dict[str, EntryPoint]:
    """Installed entry points of one kind (``optimizer``, ``evaluator`` or ``detector``), by name."""
    return {ep.name: ep for ep in entry_points(group=GROUPS[kind])}


def load(kind: str, name: str) -> Any:
    """The class registered as ``name``; a ConfigError lists what is installed."""
    eps = available(kind)
    if name not in eps:
        known = ", ".join(sorted(eps)) or "none"
        raise ConfigError(f"unknown {kind} '{name}'; installed {kind}s: {known}")
    try:
        return eps[name].load()
    except (ImportError, AttributeError) as exc:
        raise ConfigError(f"{kind} '{name}' is registered as {eps[name].value} but cannot be loaded: {exc}") from exc


def unavailable(kind: str, name: str) -> str | None:
    """Why the component registered as ``name`` cannot be used here (it cannot be loaded,
    or its class's ``unavailable()`` says why), or None when it can."""
    try:
        cls = load(kind, name)
    except ConfigError as err:
        return str(err)
    check = getattr(cls, "unavailable", None)
    return check() if check is not None else None


def _build(kind: str, name: str, params: dict[str, Any]) -> object:
    cls = load(kind, name)
    check = getattr(cls, "unavailable", None)
    reason = check() if check is not None else None
    if reason:
        raise ConfigError(f"{kind} '{name}' is unavailable: {reason}")
    try:
        return cls(**params)
    except TypeError as exc:
        raise ConfigError(f"{kind} '{name}': bad parameters {sorted(params)}: {exc}") from None


def make_optimizer(name: str, **params: Any) -> Optimizer:
    """Build the optimiser registered as ``name`` with its config parameters."""
    return cast(Optimizer, _build("optimizer", name, params))


def make_evaluator(name: str, **params: Any) -> Evaluator:
    """Build the evaluator registered as ``name`` with its config parameters."""
    return cast(Evaluator, _build("evaluator", name, params))


def make_detector(name: str, **params: Any) -> Detector:
    """Build the keypoint detector registered as ``name`` with its parameters."""
    return cast(Detector, _build("detector", name, params))


def describe() -> str:
    """Text listing every installed optimiser, evaluator and detector with where it comes from, and
    for one that cannot be used here, why (see :func:`unavailable`)."""
    lines = []
    for kind in GROUPS:
        lines.append(f"{kind}s ({GROUPS[kind]}):")
        for name, ep in sorted(available(kind).items()):
            dist = ep.dist.name if ep.dist is not None else "?"
            lines.append(f"  {name:<16} {ep.value}  [{dist}]")
            reason = unavailable(kind, name)
            if reason:
                lines.append(f"  {'':<16} unavailable: {reason}")
    return "\n".join(lines)
