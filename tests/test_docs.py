"""The documentation works as shown: README.md, docs/*.md and docs/results/*.md.

The fenced blocks are read from every page:

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

Besides: every relative link between the pages resolves, down to its heading; the README
stays a front door of at most 250 lines; its layer tables agree with ``LAYERS`` of
tests/test_layers.py, their one owner, and its table of make targets with the Makefile's
help; every page is in mkdocs.yml's nav; every generated results page starts with the
stamp of its run; no page names the package's version.
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
import yaml
from omegaconf import OmegaConf

from mmocap import config, registry
from mmocap.testing.evaluators import EvaluatorConformance
from mmocap.testing.optimizers import OptimizerConformance
from tests.test_layers import LAYERS

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"
PAGES = [README, *sorted(DOCS.glob("*.md")), *sorted((DOCS / "results").glob("*.md"))]
README_MAX_LINES = 250
SHELL = ("", "sh", "bash", "shell", "console")
LANGUAGES = ("python", "toml", "yaml", *SHELL)
FENCE = re.compile(r"^(?P<indent>\s*)```(?P<lang>[\w-]*)\s*$")
HEADING = re.compile(r"^#{1,6}\s+(?P<title>.+?)\s*$")
SUITES = (OptimizerConformance, EvaluatorConformance)


def page_name(path: Path) -> str:
    return path.relative_to(REPO).as_posix()


@dataclass(frozen=True)
class Block:
    lang: str
    code: str
    line: int  # page line of the first line of code (1-based)
    section: tuple  # (page, the nearest heading above it)

    @property
    def id(self) -> str:
        return f"{self.section[0]}:{self.lang or 'shell'}@{self.line}"


def read_blocks(text: str, page: str) -> list[Block]:
    """The fenced code blocks of a Markdown page, dedented by their fence's indentation."""
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
                raise ValueError(f"{page}:{i + 1}: the code block is never closed")
            body = [line[indent:] if line[:indent].isspace() else line.lstrip() for line in lines[start:end]]
            blocks.append(Block(fence["lang"], "\n".join(body) + "\n", start + 1, (page, section)))
            i = end
        i += 1
    return blocks


BLOCKS = [block for path in PAGES for block in read_blocks(path.read_text(encoding="utf-8"), page_name(path))]


def of(*langs: str) -> list[Block]:
    return [b for b in BLOCKS if b.lang in langs]


def params(blocks: list[Block]) -> list:
    return [pytest.param(b, id=b.id) for b in blocks]


# -- python ------------------------------------------------------------------------------------


def sections() -> list[tuple]:
    """Sections (page, heading) holding python blocks, in page order."""
    return list(dict.fromkeys(b.section for b in of("python")))


def run_section(section: tuple) -> dict:
    """Run the section's python blocks in order in one namespace; returns the namespace.
    Tracebacks give the page's line numbers."""
    namespace = {"__name__": f"docs_{slug(section)}"}
    for block in (b for b in of("python") if b.section == section):
        exec(compile("\n" * (block.line - 1) + block.code, str(REPO / section[0]), "exec"), namespace)
    return namespace


def slug(section: tuple) -> str:
    return re.sub(r"\W+", "_", " ".join(section)).strip("_").lower()


def section_id(section: tuple) -> str:
    return f"{section[0]}:{section[1]}"


@pytest.mark.parametrize("section", sections(), ids=section_id)
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
    """What one section of the docs says a plugin is: its classes (from the python blocks),
    entry points (toml) and configs (yaml)."""

    section: tuple
    namespace: dict
    entry_points: list[EntryPoint]
    configs: dict  # (group, name) -> YAML text
    package_data: dict  # package -> patterns
    find: dict  # [tool.setuptools.packages.find]

    @classmethod
    def of_section(cls, section: tuple) -> Plugin:
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
        module = types.ModuleType(f"docs_{slug(self.section)}")
        module.__dict__.update(self.namespace)
        for ep in self.entry_points:
            monkeypatch.setitem(sys.modules, ep.module, module)
        available = registry.available

        def with_docs(kind: str) -> dict:
            extra = {ep.name: ep for ep in self.entry_points if ep.group == registry.GROUPS[kind]}
            return {**available(kind), **extra}

        monkeypatch.setattr(registry, "available", with_docs)
        for (group, name), text in self.configs.items():
            (folder / group).mkdir(parents=True, exist_ok=True)
            (folder / group / f"{name}.yaml").write_text(text)
        compose = config.compose

        def compose_with_docs(overrides=(), **kw):
            return compose([*overrides, f"hydra.searchpath=[file://{folder}]"], **kw)

        monkeypatch.setattr(config, "compose", compose_with_docs)


def plugin_sections() -> list[tuple]:
    return [s for s in dict.fromkeys(b.section for b in of("toml")) if any(b.section == s for b in of("python"))]


@pytest.mark.parametrize("section", plugin_sections(), ids=section_id)
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
        assert f"{package}*" in plugin.find.get("include", [])
        assert "hydra_plugins*" in plugin.find["include"]
        assert plugin.find.get("namespaces") is True
        assert f"conf/{kind}/*.yaml" in plugin.package_data.get(package, [])
    for search in (
        c
        for c in plugin.namespace.values()
        if isinstance(c, type) and issubclass(c, SearchPathPlugin) and c is not SearchPathPlugin
    ):
        path = ConfigSearchPathImpl()
        search().manipulate_search_path(path)
        assert [p.path for p in path.get_path()] == [f"pkg://{package}.conf"]


def conformance_classes():
    """Test classes running the conformance suites the docs' sections define, each with
    the section's plugin registered; a section whose code fails defines none (its
    test_python_blocks_run fails)."""
    made = {}
    for section in plugin_sections():
        try:
            plugin = Plugin.of_section(section)
        except Exception:
            continue
        for suite in (
            c for c in plugin.namespace.values() if isinstance(c, type) and issubclass(c, SUITES) and c not in SUITES
        ):
            name = f"TestDocs{suite.__name__.removeprefix('Test')}"

            @pytest.fixture(autouse=True)
            def registered(self, monkeypatch, tmp_path, plugin=plugin):
                plugin.register(monkeypatch, tmp_path)

            made[name] = type(name, (suite,), {"registered": registered, "__module__": __name__})
    return made


globals().update(conformance_classes())


def test_the_docs_run_both_conformance_suites():
    suites = {
        base
        for name, cls in globals().items()
        if name.startswith("TestDocs")
        for base in SUITES
        if issubclass(cls, base)
    }
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
    assert not found, f"{block.section[0]}:{block.line}: " + "; ".join(found)


def test_the_checks_find_what_they_should():
    targets, names = make_targets(), subcommands()
    assert {"demo", "test", "test-all", "install"} <= targets
    assert "PY" not in targets
    assert {"track", "generate", "list", "bench", "foreground-quality"} <= names
    bad = "make nope\n.venv/bin/mmocap trak x=1\npython -m mmocap.bench all\ncd a && make demo SCALE=x\n"
    found = [p for c in commands(bad) for p in problems(c, targets, names)]
    assert len(found) == 3
    assert "make nope" in found[0]
    assert "trak" in found[1]
    assert "mmocap.bench" in found[2]
    good = (
        "mmocap -m +experiment=x\nmmocap dataset=humaneva \\\n  x=1\npython -m mmocap list\nmake table4 SCALE=default"
    )
    assert not [p for c in commands(good) for p in problems(c, targets, names)]


def test_every_block_has_a_known_language():
    assert BLOCKS
    assert all(b.lang in LANGUAGES for b in BLOCKS), [b.id for b in BLOCKS if b.lang not in LANGUAGES]
    assert of("python")
    assert of("toml")
    assert of("yaml")
    assert of(*SHELL)


# -- links, length, tables, nav, stamps ----------------------------------------------------------

LINK = re.compile(r"(?<!!)\[[^\]]*\]\((?P<target>[^)\s]+)\)")


def prose(text: str) -> list[tuple[int, str]]:
    """The lines of a Markdown text outside its code blocks, numbered from 1."""
    lines, inside = [], False
    for number, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line) or (inside and line.strip() == "```"):
            inside = not inside
        elif not inside:
            lines.append((number, line))
    return lines


def page_prose(path: Path) -> list[tuple[int, str]]:
    return prose(path.read_text(encoding="utf-8"))


def heading_anchors(path: Path) -> set[str]:
    """The anchors of a page's headings, as MkDocs makes them (Python-Markdown's toc)."""
    return {anchor(m["title"]) for _, line in page_prose(path) if (m := HEADING.match(line))}


def anchor(title: str) -> str:
    """A heading's anchor on the site; GitHub's is the same for every heading a page links
    to (both drop punctuation and lower the case; the site also folds runs of hyphens and
    spaces, which :func:`test_linked_headings_have_the_same_anchor_on_github` rules out)."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", title).replace("`", "")
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def github_anchor(title: str) -> str:
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", title).replace("`", "")
    return re.sub(r"[^\w\s-]", "", text).strip().lower().replace(" ", "-")


def relative_links(text: str) -> list[tuple[int, str]]:
    """(line, target) of each link of a Markdown text to a file or heading: not in code,
    not to a URL, not an image."""
    return [
        (number, m["target"])
        for number, line in prose(text)
        for m in LINK.finditer(re.sub(r"`[^`]*`", "", line))
        if not re.match(r"[a-z]+:", m["target"])
    ]


@pytest.mark.parametrize("path", PAGES, ids=page_name)
def test_relative_links_resolve(path):
    broken = []
    for number, target in relative_links(path.read_text(encoding="utf-8")):
        file, _, fragment = target.partition("#")
        linked = (path.parent / file).resolve() if file else path
        if not linked.exists():
            broken.append(f"{page_name(path)}:{number}: {target}: no such file")
        elif fragment and linked.suffix == ".md" and fragment not in heading_anchors(linked):
            broken.append(f"{page_name(path)}:{number}: {target}: no such heading in {linked.name}")
    assert not broken, "\n".join(broken)


def test_linked_headings_have_the_same_anchor_on_github():
    headings = [m["title"] for path in PAGES for _, line in page_prose(path) if (m := HEADING.match(line))]
    differ = [title for title in headings if anchor(title) != github_anchor(title)]
    assert not differ, f"headings whose anchors differ on GitHub and on the site: {differ}"


def test_the_link_checks_find_what_they_should():
    assert (
        anchor("Foreground: background models and `make foreground`")
        == "foreground-background-models-and-make-foreground"
    )
    assert anchor("The papers' conclusions, re-tested") == "the-papers-conclusions-re-tested"
    assert github_anchor("a - b") != anchor("a - b")
    text = "[a](usage.md#x) `[b](no.md)` [c](https://hydra.cc) ![d](e.png)\n```\n[f](g.md)\n```\n[h](#y)\n"
    assert relative_links(text) == [(1, "usage.md#x"), (5, "#y")]


def test_the_readme_is_a_front_door():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines; move text into docs/"


def tables(path: Path, header: str) -> list[list[list[str]]]:
    """The Markdown tables of a page whose header row starts with ``header``: rows of cells."""
    found, rows = [], None
    for _, line in page_prose(path):
        if line.startswith(header):
            rows = []
            found.append(rows)
        elif rows is not None and line.startswith("|"):
            if not re.fullmatch(r"\|( *:?-+:? *\|)+", line.strip()):
                rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
        else:
            rows = None
    return found


def module_of(name: str) -> str:
    """``cli.py`` -> ``mmocap.cli``, ``report/`` -> ``mmocap.report``, ``__init__.py`` -> ``mmocap``;
    the file or folder must exist as written."""
    assert (REPO / "mmocap" / name).exists(), f"the layer table names {name}, but mmocap/{name} does not exist"
    assert (REPO / "mmocap" / name).is_dir() == name.endswith("/"), (
        f"the layer table names {name}, but mmocap/{name} does not exist as written (a module ends "
        "in .py, a package in /)"
    )
    stem = name.removesuffix(".py").removesuffix("/").replace("/", ".")
    return "mmocap" if stem == "__init__" else f"mmocap.{stem}"


LAYER_PAGES = [README, DOCS / "architecture.md"]


@pytest.mark.parametrize("path", LAYER_PAGES, ids=page_name)
def test_the_layer_table_is_that_of_the_layer_test(path):
    """tests/test_layers.py's LAYERS is the one owner of the layers; the pages show it."""
    found = tables(path, "| layer | modules |")
    assert len(found) == 1, f"{page_name(path)}: one layer table expected, found {len(found)}"
    shown = [(row[0], [module_of(m) for m in re.findall(r"`([^`]+)`", row[1])]) for row in found[0]]
    assert shown == [(name, list(prefixes)) for name, prefixes in LAYERS]


def documented_targets() -> dict[str, str]:
    """The Makefile's targets that ``make help`` lists, with their help text."""
    text = (REPO / "Makefile").read_text()
    return {m[1]: m[2] for m in re.finditer(r"^([A-Za-z0-9_-]+):.*?## (.*)$", text, re.M)}


def test_the_readme_lists_the_targets_make_help_lists():
    found = tables(README, "| target |")
    assert len(found) == 1, "README.md: one table of make targets expected"
    listed = {target for row in found[0] for target in re.findall(r"`([^`]+)`", row[0])}
    assert listed == set(documented_targets()), (
        f"only in the README: {sorted(listed - set(documented_targets()))}; "
        f"only in make help: {sorted(set(documented_targets()) - listed)}"
    )


def nav_pages(nav) -> list[str]:
    if isinstance(nav, str):
        return [nav]
    if isinstance(nav, dict):
        return [page for value in nav.values() for page in nav_pages(value)]
    return [page for item in nav for page in nav_pages(item)]


def test_every_page_is_in_the_site_nav():
    config = yaml.safe_load((REPO / "mkdocs.yml").read_text())
    in_nav = nav_pages(config["nav"])
    pages = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md"))
    assert sorted(in_nav) == pages, f"pages not in nav: {sorted(set(pages) - set(in_nav))}"
    assert config.get("strict") is True


# "Generated by `make bench` on 2026-11-27 on <machine>", a time of day after the date allowed
STAMP = re.compile(r"Generated by `make [^`]+` on \d{4}-\d{2}-\d{2}( \d{2}:\d{2}( UTC)?)? on \S.*")


@pytest.mark.parametrize("path", sorted((DOCS / "results").glob("*.md")), ids=page_name)
def test_a_results_page_starts_with_the_stamp_of_its_run(path):
    first = path.read_text(encoding="utf-8").splitlines()[0]
    assert STAMP.fullmatch(first), f"{page_name(path)}: first line {first!r} is not a stamp {STAMP.pattern}"


def test_no_page_names_the_version():
    """The version has one owner, pyproject.toml; a page that names it goes stale."""
    version = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    naming = [
        f"{page_name(p)}:{n}"
        for p in PAGES
        for n, line in enumerate(p.read_text().splitlines(), 1)
        if re.search(rf"(?<![\d.]){re.escape(version)}(?![\d.])", line)
    ]
    assert not naming, f"pages naming the version {version}: {naming}"
