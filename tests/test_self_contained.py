"""A fresh clone works with nothing beside it: no scenario, sweep, model or source file refers to
a path outside the repository, and every file they need is under version control."""

from __future__ import annotations

import ast
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from pydantic import BaseModel

from humimic.paths import PROJECT_DIR, SCENARIOS_DIR
from humimic.scenario import load_scenario
from humimic.sweep.config import load_sweep

ROOT = Path(__file__).resolve().parent.parent
SWEEPS_DIR = ROOT / "sweeps"
#: Directories whose files ship with the code (a fresh clone must have them all).
SHIPPED = ("models", "data", "scenarios", "sweeps")
#: Absolute paths into a machine's own file system (outputs go to tempfile.gettempdir()).
ABSOLUTE = re.compile(r"(?<![\w.])/(?:tmp|work|home|root|usr|opt|mnt|data|srv|var|Users)\b"
                      r"[^\s'\"]*")
#: Relative references that climb out of a directory.
CLIMBING = re.compile(r"(?<![\w.])(?:\.\./)+[^\s'\"]*")
#: Directories a relative reference in the sources may be written against.
BASES = (ROOT, SCENARIOS_DIR, SWEEPS_DIR, ROOT / "src" / "humimic", ROOT / "tests",
         ROOT / "benchmarks", ROOT / "models")


def _paths(model: BaseModel, prefix: str = ""):
    """Every ``(dotted key, Path)`` in a validated scenario or sweep."""
    for name in type(model).model_fields:
        value = getattr(model, name)
        items = value if isinstance(value, list) else [value]
        for i, item in enumerate(items):
            key = f"{prefix}{name}" + (f".{i}" if isinstance(value, list) else "")
            if isinstance(item, BaseModel):
                yield from _paths(item, key + ".")
            elif isinstance(item, Path):
                yield key, item


def _inside(path: Path) -> bool:
    return path.resolve().is_relative_to(ROOT)


def test_the_package_runs_from_this_repository():
    assert PROJECT_DIR.resolve() == ROOT


@pytest.mark.parametrize("name", sorted(p.name for p in SCENARIOS_DIR.glob("*.yaml")))
def test_a_scenario_refers_only_to_files_in_the_repository(name):
    scenario = load_scenario(SCENARIOS_DIR / name)
    for key, path in _paths(scenario):
        assert _inside(path), f"{name}: {key} = {path} is outside {ROOT}"


@pytest.mark.parametrize("name", sorted(p.name for p in SWEEPS_DIR.glob("*.yaml")))
def test_a_sweep_refers_only_to_files_in_the_repository(name):
    sweep = load_sweep(SWEEPS_DIR / name)
    assert _inside(sweep.scenario_path), f"{name}: scenario {sweep.scenario_path}"
    for key, path in _paths(sweep.config):
        assert _inside(SWEEPS_DIR / path), f"{name}: {key} = {path} is outside {ROOT}"


def _strings(path: Path):
    """``(line, text)`` of every string in a Python file (docstrings and f-string parts too)."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            yield node.lineno, node.value


def _text_files():
    for sub in ("src", "tests", "benchmarks"):
        for path in sorted((ROOT / sub).rglob("*.py")):
            yield path, list(_strings(path))
    for sub in ("scenarios", "sweeps", "models"):
        for path in sorted((ROOT / sub).rglob("*")):
            if path.suffix in (".yaml", ".yml", ".xml"):
                yield path, list(enumerate(path.read_text().splitlines(), 1))


def test_no_source_or_scenario_file_refers_to_a_path_outside_the_repository():
    """Absolute paths into the machine's directories (home, tmp, work...) and ``../``
    references that leave the repository (or lead nowhere) from every directory they could be
    meant for."""
    bad = []
    for path, strings in _text_files():
        rel = path.relative_to(ROOT)
        for line, text in strings:
            bad += [f"{rel}:{line}: {m}" for m in ABSOLUTE.findall(text)]
            for ref in CLIMBING.findall(text):
                ref = ref.rstrip(".,;:)`")
                targets = [base / ref for base in (path.parent, *BASES)]
                if not any(_inside(t) and t.exists() for t in targets):
                    bad.append(f"{rel}:{line}: {ref}")
    assert not bad, "paths outside the repository:\n" + "\n".join(bad)


def test_models_refer_only_to_files_beside_them():
    """Every ``file=`` of an MJCF (resolved against its ``texturedir`` / ``meshdir`` /
    ``assetdir``, as MuJoCo does) is a file in the repository."""
    for xml in sorted((ROOT / "models").rglob("*.xml")):
        text = xml.read_text()
        dirs = dict(re.findall(r'\b(texturedir|meshdir|assetdir)="([^"]+)"', text))
        for tag, ref in re.findall(r'<(\w+)[^>]*\bfile="([^"]+)"', text):
            sub = dirs.get({"texture": "texturedir", "mesh": "meshdir",
                            "hfield": "meshdir"}.get(tag, ""), dirs.get("assetdir", ""))
            target = xml.parent / sub / ref
            assert _inside(target) and target.is_file(), f"{xml.name}: <{tag} file={ref}>"


def test_every_shipped_file_is_under_version_control():
    """A file the scenarios or tests read but git does not track would be missing from a
    fresh clone (``git clone`` copies only tracked files)."""
    git = shutil.which("git")
    if git is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    out = subprocess.run([git, "status", "--porcelain", "--ignored", "--untracked-files=all",
                          "--", *SHIPPED], cwd=ROOT, capture_output=True, text=True, check=True)
    untracked = [line for line in out.stdout.splitlines() if line[:2] in ("??", "!!")]
    assert not untracked, "not tracked by git:\n" + "\n".join(untracked)
