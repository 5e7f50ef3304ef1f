"""A sweep's pin: digests of mmocap's code and of the config files, plugin and package
versions, and what :func:`mmocap.pin.changes` names when one of them moves."""

import hashlib
import importlib.metadata
import importlib.resources
import json
import time
from pathlib import Path

import pytest

from mmocap import pin

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ("pkg", "mmocap.conf")


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_code_digests_every_file_of_the_package_but_caches_and_configs():
    code = pin.code()
    package = Path(pin.__file__).parent
    assert code["mmocap/pipeline.py"] == sha256(package / "pipeline.py")
    assert code["mmocap/evaluators/kernels/silhouette.cl"] == sha256(package / "evaluators/kernels/silhouette.cl")
    assert "mmocap/body/assets/makehuman/base.obj.gz" in code
    assert not [name for name in code if "__pycache__" in name or name.startswith("mmocap/conf/")]
    assert len(code) == len([p for p in package.rglob("*") if p.is_file() and "__pycache__" not in p.parts])


def test_configs_digest_every_yaml_file_of_each_source_with_files(tmp_path):
    (tmp_path / "optimizer").mkdir()
    (tmp_path / "optimizer" / "mine.yaml").write_text("popsize: 8\n")
    (tmp_path / "notes.txt").write_text("not a config\n")
    (tmp_path / ".hydra").mkdir()
    (tmp_path / ".hydra" / "config.yaml").write_text("a job's saved config\n")
    (tmp_path / "sweep").mkdir()
    (tmp_path / "sweep" / "multirun.yaml").write_text("what Hydra wrote when a sweep started\n")
    found = pin.configs([SHIPPED, ("file", str(tmp_path)), ("structured", "")])
    assert list(found) == ["pkg://mmocap.conf", f"file://{tmp_path}"]
    assert found[f"file://{tmp_path}"] == {"optimizer/mine.yaml": sha256(tmp_path / "optimizer" / "mine.yaml")}
    shipped = importlib.resources.files("mmocap.conf")
    assert found["pkg://mmocap.conf"]["optimizer/cmaes.yaml"] == sha256(Path(str(shipped / "optimizer" / "cmaes.yaml")))
    assert len(found["pkg://mmocap.conf"]) == len(list(Path(str(shipped)).rglob("*.yaml")))


def test_a_source_that_is_not_installed_or_not_there_has_no_files(tmp_path):
    found = pin.configs([("pkg", "no_such_package.conf"), ("file", str(tmp_path / "missing"))])
    assert found == {"pkg://no_such_package.conf": {}, f"file://{tmp_path / 'missing'}": {}}


def test_plugins_are_the_distributions_registering_mmocaps_entry_points():
    plugins = pin.plugins()
    assert plugins["mmocap"] == importlib.metadata.version("mmocap")
    try:
        assert plugins["mmocap-pycma"] == importlib.metadata.version("mmocap-pycma")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("the example plugin mmocap-pycma is not installed (make install installs it)")
    assert "numpy" not in plugins


def test_the_same_process_takes_the_same_pin_and_changes_name_nothing():
    first = pin.take([SHIPPED])
    assert pin.changes(first, pin.take([SHIPPED])) == []
    assert json.loads(json.dumps(first)) == first  # sweep.json holds it as it is


def test_changes_name_each_file_plugin_and_package_that_moved(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    folder = tmp_path / "conf"
    (folder / "optimizer").mkdir(parents=True)
    (folder / "optimizer" / "mine.yaml").write_text("popsize: 8\n")
    (folder / "old.yaml").write_text("a: 1\n")
    sources = [("file", str(folder))]
    before = pin.take(sources)
    (folder / "optimizer" / "mine.yaml").write_text("popsize: 9\n")
    (folder / "old.yaml").unlink()
    (folder / "new.yaml").write_text("b: 2\n")
    after = pin.take(sources)
    after["code"] = {**after["code"], "mmocap/pipeline.py": "0" * 64}
    after["plugins"] = {**after["plugins"], "mmocap-pycma": "9.9.9", "mmocap-extra": "0.1"}
    after["packages"] = {**after["packages"], "numpy": "0.0.1"}
    found = pin.changes(before, after)
    assert found[:3] == ["conf/optimizer/mine.yaml", "conf/new.yaml (new)", "conf/old.yaml (deleted)"]
    assert found[3] == "mmocap/pipeline.py"
    assert "plugin mmocap-extra 0.1 (new)" in found
    assert f"package numpy ({before['packages']['numpy']}, now 0.0.1)" in found
    if "mmocap-pycma" in before["plugins"]:
        assert f"plugin mmocap-pycma ({before['plugins']['mmocap-pycma']}, now 9.9.9)" in found
    assert pin.named(found).endswith(f" and {len(found) - 3} more")
    assert pin.named(found[:1]) == "conf/optimizer/mine.yaml"


def test_a_config_file_is_named_where_the_user_finds_it(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    assert pin.config_file("pkg://mmocap.conf", "optimizer/cmaes.yaml") == "conf/optimizer/cmaes.yaml"
    monkeypatch.chdir(tmp_path)
    assert pin.config_file("pkg://mmocap.conf", "optimizer/cmaes.yaml") == str(ROOT / "conf/optimizer/cmaes.yaml")
    assert pin.config_file("pkg://gone.conf", "a.yaml") == "pkg://gone.conf/a.yaml"


def test_taking_the_pin_costs_milliseconds():
    """Every job takes it: a few hundred small files and the installed distributions."""
    sources = [("pkg", "hydra.conf"), SHIPPED]
    pin.take(sources)
    seconds = []
    for _ in range(5):
        start = time.perf_counter()
        pin.take(sources)
        seconds.append(time.perf_counter() - start)
    assert min(seconds) < 0.5, f"taking the pin took {min(seconds) * 1000:.0f} ms"
