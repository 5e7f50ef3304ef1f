"""Layers flow one way: no module of mmocap imports from a layer above its own.

The layers, from the top down (a module may import its own layer and those below):
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "mmocap"

# Top first. A module is placed by its dotted name's longest prefix found here.
LAYERS = [
    ("command line", ["mmocap.cli", "mmocap.__main__"]),
    (
        "jobs",
        [
            "mmocap.pipeline",
            "mmocap.preflight",
            "mmocap.sweep",
            "mmocap.bench",
            "mmocap.report",
            "mmocap.testing",
            "mmocap.data.recording.commands",
        ],
    ),
    ("analysis and run writers", ["mmocap.analysis", "mmocap.writers"]),
    ("stages", ["mmocap.stages"]),
    ("components", ["mmocap.evaluators", "mmocap.optimizers", "mmocap.data", "mmocap.body", "mmocap.camera"]),
    (
        "foundations",
        [
            "mmocap.api",
            "mmocap.registry",
            "mmocap.errors",
            "mmocap.io",
            "mmocap.validate",
            "mmocap.bitmask",
            "mmocap.config",
            "mmocap.provenance",
            "mmocap.pin",
            "mmocap.video",
            "mmocap.run_folder",
            "mmocap",
        ],
    ),
]
__doc__ += "\n".join(f"{i}. {name}: {', '.join(prefixes)}" for i, (name, prefixes) in enumerate(LAYERS))


def layer_of(module: str) -> int:
    """Index into LAYERS (0 = top) of a dotted module name inside mmocap."""
    best = None
    for index, (_, prefixes) in enumerate(LAYERS):
        for prefix in prefixes:
            nested = prefix != "mmocap" and module.startswith(prefix + ".")  # mmocap itself only
            if (module == prefix or nested) and (best is None or len(prefix) > best[1]):
                best = (index, len(prefix))
    assert best is not None, f"{module} is in no layer: add it to LAYERS"
    return best[0]


def modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        yield ".".join(parts[:-1] if parts[-1] == "__init__" else parts), path


def imported(path: Path, module: str) -> set[str]:
    """The mmocap modules ``path`` imports (anywhere in it, functions included)."""
    names = set()
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parents = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(parents + ([base] if base else []))
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)
    return {n for n in names if n == "mmocap" or n.startswith("mmocap.")}


@pytest.mark.parametrize(("module", "path"), list(modules()), ids=[m for m, _ in modules()])
def test_imports_only_its_own_layer_or_below(module, path):
    own = layer_of(module)
    upward = sorted(name for name in imported(path, module) if layer_of(name) < own)
    assert not upward, f"{module} ({LAYERS[own][0]}) imports from above: {upward}"


def test_a_module_imported_from_above_is_reported():
    assert layer_of("mmocap.cli") < layer_of("mmocap.pipeline") < layer_of("mmocap.analysis.results")
    assert layer_of("mmocap.stages.tracking") < layer_of("mmocap.evaluators.opencl") < layer_of("mmocap.io")
