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
