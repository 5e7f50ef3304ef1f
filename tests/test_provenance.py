"""Provenance: versions, the checkout's commit, and where each component comes from."""

import importlib.metadata
import subprocess
from pathlib import Path

import pytest

from mmocap import provenance


def test_facts_name_the_checkouts_commit_and_the_versions():
    facts = provenance.facts()
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=Path(__file__).parent, text=True, capture_output=True
    ).stdout.strip()
    assert facts["git_commit"] == head
    assert facts["versions"]["numpy"] == importlib.metadata.version("numpy")


def test_components_name_the_distribution_and_version_that_registered_them():
    found = provenance.components({"optimizer": "cmaes", "evaluator": "numpy"})
    assert found["optimizer"] == {
        "name": "cmaes",
        "entry_point": "mmocap.optimizers.cmaes:CMAES",
        "distribution": "mmocap",
        "version": importlib.metadata.version("mmocap"),
    }
    assert found["evaluator"]["distribution"] == "mmocap"
    assert provenance.components({"optimizer": "nope"})["optimizer"]["distribution"] is None


def test_a_plugin_is_named_with_its_own_version():
    try:
        version = importlib.metadata.version("mmocap-pycma")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("the example plugin mmocap-pycma is not installed (make install installs it)")
    found = provenance.components({"optimizer": "pycma"})["optimizer"]
    assert (found["distribution"], found["version"]) == ("mmocap-pycma", version)


def test_line_names_mmocap_the_commit_and_the_source():
    line = provenance.line("runs.csv")
    assert line.startswith("mmocap ")
    assert line.endswith("source runs.csv")
    assert f"commit {provenance.facts()['git_commit'][:10]}" in line


def test_changed_files_are_the_uncommitted_and_untracked_files_under_the_paths(tmp_path, monkeypatch):
    def git(*args):
        subprocess.run(["git", *args], cwd=tmp_path, check=True, capture_output=True)

    git("init", "-q")
    for name in ("mmocap/a.py", "mmocap/b.py", "conf/x.yaml", "docs/page.md"):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text("1\n")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "first")
    monkeypatch.setattr(provenance, "_checkout", lambda: tmp_path)
    assert provenance.changed_files(("mmocap", "conf")) == []
    (tmp_path / "mmocap/a.py").write_text("2\n")
    (tmp_path / "conf/new yaml.yaml").write_text("new\n")
    (tmp_path / "docs/page.md").write_text("2\n")
    git("mv", "mmocap/b.py", "mmocap/c.py")
    assert provenance.changed_files(("mmocap", "conf")) == ["conf/new yaml.yaml", "mmocap/a.py", "mmocap/c.py"]


def test_an_installed_wheel_has_no_changed_files(monkeypatch):
    monkeypatch.setattr(provenance, "_checkout", lambda: None)
    assert provenance.changed_files(("mmocap",)) is None
