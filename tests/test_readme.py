"""Every code block of README.md works as shown.

The fenced blocks are read from the README:

- ```python blocks run in order, one namespace per section (the blocks under one heading
  build on each other); a conformance class they define (a subclass of
  ``OptimizerConformance`` or ``EvaluatorConformance``) runs here as a test class of its own,
  with the section's classes registered under the entry points of its ```toml block and
  its ```yaml config on the config search path, as an installed plugin would be;
- ```toml blocks parse with tomllib, ```yaml blocks with OmegaConf; a registry config
  (``_target_: mmocap.registry.make_*``) lists the constructor's arguments with the code's
  defaults;
- shell blocks (``` without a language, ```sh, ```bash) are not run: they may name only
  targets of the Makefile (``make X``) and subcommands of ``mmocap`` (``mmocap --help``),
  and no ``python -m mmocap.<module>``.
"""
from __future__ import annotations

import inspect
import re
import shlex
import sys
import tomllib
import types
from dataclasses import dataclass
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from mmocap import config, registry
from mmocap.testing.evaluators import EvaluatorConformance
from mmocap.testing.optimizers import OptimizerConformance

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
SHELL = ("", "sh", "bash", "shell", "console")
LANGUAGES = ("python", "toml", "yaml", *SHELL)
FENCE = re.compile(r"^(?P<indent>\s*)```(?P<lang>[\w-]*)\s*$")
HEADING = re.compile(r"^#{1,6}\s+(?P<title>.+?)\s*$")
SUITES = (OptimizerConformance, EvaluatorConformance)


@dataclass(frozen=True)
class Block:
    lang: str
    code: str
    line: int       # README line of the first line of code (1-based)
    section: str    # the nearest heading above it

    @property
    def id(self) -> str:
        return f"{self.lang or 'shell'}@{self.line}"


def read_blocks(text: str) -> list[Block]:
    """The fenced code blocks of a Markdown text, dedented by their fence's indentation."""
    blocks, section, lines = [], "", text.splitlines()
    i = 0
    while i < len(lines):
        heading, fence = HEADING.match(lines[i]), FENCE.match(lines[i])
        if heading and not lines[i].startswith(" "):
            section = heading["title"]
        elif fence:
            indent, start = len(fence["indent"]), i + 1
            end = next((j for j in range(start, len(lines)) if lines[j].strip() == "```"), None)
            if end is None:
                raise ValueError(f"README.md:{i + 1}: the code block is never closed")
            body = [line[indent:] if line[:indent].isspace() else line.lstrip() for line in lines[start:end]]
            blocks.append(Block(fence["lang"], "\n".join(body) + "\n", start + 1, section))
            i = end
        i += 1
    return blocks


BLOCKS = read_blocks(README.read_text(encoding="utf-8"))


def of(*langs: str) -> list[Block]:
    return [b for b in BLOCKS if b.lang in langs]


def params(blocks: list[Block]) -> list:
    return [pytest.param(b, id=b.id) for b in blocks]


# -- python ------------------------------------------------------------------------------------

def sections() -> list[str]:
    """Sections holding python blocks, in README order."""
    return list(dict.fromkeys(b.section for b in of("python")))


def run_section(section: str) -> dict:
    """Run the section's python blocks in order in one namespace; returns the namespace.
    Tracebacks give README.md line numbers."""
    namespace = {"__name__": f"readme_{slug(section)}"}
    for block in (b for b in of("python") if b.section == section):
        exec(compile("\n" * (block.line - 1) + block.code, str(README), "exec"), namespace)
    return namespace


def slug(text: str) -> str:
    return re.sub(r"\W+", "_", text).strip("_").lower()


@pytest.mark.parametrize("section", sections())
def test_python_blocks_run(section):
    run_section(section)


# -- toml and yaml -----------------------------------------------------------------------------

@pytest.mark.parametrize("block", params(of("toml")))
def test_toml_blocks_parse(block):
    tomllib.loads(block.code)


@pytest.mark.parametrize("block", params(of("yaml")))
def test_yaml_blocks_parse(block):
    assert OmegaConf.create(block.code) is not None


@dataclass
class Plugin:
    """What one README section says a plugin is: its classes (from the python blocks),
    entry points (toml) and configs (yaml)."""
    section: str
    namespace: dict
    entry_points: list[EntryPoint]
    configs: dict          # (group, name) -> YAML text
    package_data: dict     # package -> patterns
    find: dict             # [tool.setuptools.packages.find]

    @classmethod
    def of_section(cls, section: str) -> Plugin:
        namespace = run_section(section)
        entry_points, package_data, find, configs = [], {}, {}, {}
        for block in (b for b in of("toml") if b.section == section):
            doc = tomllib.loads(block.code)
            for group, names in doc.get("project", {}).get("entry-points", {}).items():
                entry_points += [EntryPoint(name, value, group) for name, value in names.items()]
            setuptools = doc.get("tool", {}).get("setuptools", {})
            package_data.update(setuptools.get("package-data", {}))
            find.update(setuptools.get("packages", {}).get("find", {}))
        for block in (b for b in of("yaml") if b.section == section):
            node = OmegaConf.create(block.code)
            target = str(node.get("_target_", ""))
            if target.startswith("mmocap.registry.make_"):
                configs[target.rpartition("make_")[2], node["name"]] = block.code
        return cls(section, namespace, entry_points, configs, package_data, find)

    def component(self, entry_point: EntryPoint):
        """The section's class an entry point names (``module:attr``, attr in the namespace)."""
        attr = entry_point.value.partition(":")[2]
        assert attr in self.namespace, f"{entry_point.value} names no class of the section's code"
        return self.namespace[attr]

    def register(self, monkeypatch, folder: Path) -> None:
        """Make the section's classes installed plugins for the test: its entry points in
        the registry (their modules are the section's namespace), its configs on the search
        path of :func:`mmocap.config.compose`."""
        module = types.ModuleType(f"readme_{slug(self.section)}")
        module.__dict__.update(self.namespace)
        for ep in self.entry_points:
            monkeypatch.setitem(sys.modules, ep.module, module)
        available = registry.available

        def with_readme(kind: str) -> dict:
            extra = {ep.name: ep for ep in self.entry_points if ep.group == registry.GROUPS[kind]}
            return {**available(kind), **extra}

        monkeypatch.setattr(registry, "available", with_readme)
        for (group, name), text in self.configs.items():
            (folder / group).mkdir(parents=True, exist_ok=True)
            (folder / group / f"{name}.yaml").write_text(text)
        compose = config.compose

        def compose_with_readme(overrides=(), **kw):
            return compose([*overrides, f"hydra.searchpath=[file://{folder}]"], **kw)

        monkeypatch.setattr(config, "compose", compose_with_readme)


def plugin_sections() -> list[str]:
    return [s for s in dict.fromkeys(b.section for b in of("toml"))
            if any(b.section == s for b in of("python"))]


@pytest.mark.parametrize("section", plugin_sections())
def test_plugin_parts_agree(section):
    """Entry points name the section's classes, whose ``name`` they are; each has a config
    whose values are the constructor's defaults; packaging ships the package, the
    ``hydra_plugins`` namespace package and the YAML; the search-path plugin adds the
    package's ``conf``."""
    from hydra._internal.config_search_path_impl import ConfigSearchPathImpl
    from hydra.plugins.search_path_plugin import SearchPathPlugin

    plugin = Plugin.of_section(section)
    assert plugin.entry_points, "no entry point"
    for ep in plugin.entry_points:
        cls = plugin.component(ep)
        kind = next(k for k, g in registry.GROUPS.items() if g == ep.group)
        assert cls.name == ep.name
        assert (kind, ep.name) in plugin.configs, f"no {kind}/{ep.name}.yaml config"
        node = OmegaConf.create(plugin.configs[kind, ep.name])
        defaults = {k: p.default for k, p in inspect.signature(cls).parameters.items()}
        assert {k: v for k, v in node.items() if k not in ("_target_", "name")} == defaults
        package = ep.module.partition(".")[0]
        assert f"{package}*" in plugin.find.get("include", []) and "hydra_plugins*" in plugin.find["include"]
        assert plugin.find.get("namespaces") is True
        assert f"conf/{kind}/*.yaml" in plugin.package_data.get(package, [])
    for search in (c for c in plugin.namespace.values()
                   if isinstance(c, type) and issubclass(c, SearchPathPlugin) and c is not SearchPathPlugin):
        path = ConfigSearchPathImpl()
        search().manipulate_search_path(path)
        assert [p.path for p in path.get_path()] == [f"pkg://{package}.conf"]


def conformance_classes():
    """Test classes running the conformance suites the README's sections define, each with
    the section's plugin registered; a section whose code fails defines none (its
    test_python_blocks_run fails)."""
    made = {}
    for section in plugin_sections():
        try:
            plugin = Plugin.of_section(section)
        except Exception:
            continue
        for suite in (c for c in plugin.namespace.values()
                      if isinstance(c, type) and issubclass(c, SUITES) and c not in SUITES):
            name = f"TestReadme{suite.__name__.removeprefix('Test')}"

            @pytest.fixture(autouse=True)
            def registered(self, monkeypatch, tmp_path, plugin=plugin):
                plugin.register(monkeypatch, tmp_path)

            made[name] = type(name, (suite,), {"registered": registered, "__module__": __name__})
    return made


globals().update(conformance_classes())


def test_the_readme_runs_both_conformance_suites():
    suites = {base for name, cls in globals().items() if name.startswith("TestReadme")
              for base in SUITES if issubclass(cls, base)}
    assert suites == set(SUITES)


# -- shell -------------------------------------------------------------------------------------

def make_targets() -> set[str]:
    text = (REPO / "Makefile").read_text()
    return {m[1] for m in re.finditer(r"^([A-Za-z0-9_.-]+)\s*:(?!=)", text, re.M)}


def subcommands() -> set[str]:
    from mmocap.cli import usage

    listed = usage().split("subcommands:\n", 1)[1].split("\n\n", 1)[0]
    return {line.split()[0] for line in listed.splitlines() if line.strip()}


def commands(code: str) -> list[list[str]]:
    """The commands of a shell block as word lists: continuation lines joined, comments
    dropped, split at ``&&``, ``||``, ``;`` and ``|``."""
    found = []
    for line in code.replace("\\\n", " ").splitlines():
        try:
            words = shlex.split(line, comments=True)
        except ValueError:  # not shell (a folder layout, say)
            words = line.split()
        command = []
        for word in [*words, ";"]:
            if word in ("&&", "||", ";", "|"):
                if command:
                    found.append(command)
                command = []
            else:
                command.append(word)
    return found


def problems(command: list[str], targets: set[str], names: set[str]) -> list[str]:
    """Why a command names something that does not exist (empty: it does not)."""
    words = list(command)
    while words and re.fullmatch(r"\w+=\S*", words[0]):  # VAR=value before the command
        words.pop(0)
    if not words:
        return []
    program, args = Path(words[0]).name, words[1:]
    if program == "make":
        goals = [a for a in args if not a.startswith("-") and "=" not in a]
        return [f"make {g}: no such target in the Makefile" for g in goals if g not in targets]
    if re.fullmatch(r"python[\d.]*", program) and args[:1] == ["-m"] and len(args) > 1:
        module, args = args[1], args[2:]
        if module.startswith("mmocap."):
            return [f"python -m {module}: module invocations are gone, use `mmocap SUBCOMMAND`"]
        if module != "mmocap":
            return []
    elif program != "mmocap":
        return []
    first = args[0] if args else ""
    if not first or first.startswith(("-", "+", "~")) or "=" in first or first in names:
        return []
    return [f"mmocap {first}: no such subcommand (mmocap --help lists {', '.join(sorted(names))})"]


@pytest.mark.parametrize("block", params(of(*SHELL)))
def test_shell_blocks_name_existing_targets_and_subcommands(block):
    targets, names = make_targets(), subcommands()
    found = [p for command in commands(block.code) for p in problems(command, targets, names)]
    assert not found, f"README.md:{block.line}: " + "; ".join(found)


def test_the_checks_find_what_they_should():
    targets, names = make_targets(), subcommands()
    assert {"demo", "test", "test-all", "install"} <= targets and "PY" not in targets
    assert {"track", "generate", "list", "bench", "foreground-quality"} <= names
    bad = "make nope\n.venv/bin/mmocap trak x=1\npython -m mmocap.bench all\ncd a && make demo SCALE=x\n"
    found = [p for c in commands(bad) for p in problems(c, targets, names)]
    assert len(found) == 3 and "make nope" in found[0] and "trak" in found[1] and "mmocap.bench" in found[2]
    good = ("mmocap -m +experiment=x\nmmocap dataset=humaneva \\\n  x=1\n"
            "python -m mmocap list\nmake table4 SCALE=default")
    assert not [p for c in commands(good) for p in problems(c, targets, names)]


def test_every_block_has_a_known_language():
    assert BLOCKS and all(b.lang in LANGUAGES for b in BLOCKS), [b.id for b in BLOCKS if b.lang not in LANGUAGES]
    assert of("python") and of("toml") and of("yaml") and of(*SHELL)
