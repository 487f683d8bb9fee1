"""The README keeps its promises to a new user: its first lines are the two fresh-machine
commands (install + demo, install + tests), the demo scenario exists, and its scenario table
names every scenario that ships."""

from __future__ import annotations

import re

from humimic.paths import PROJECT_DIR, SCENARIOS_DIR

README = (PROJECT_DIR / "README.md").read_text(encoding="utf-8")


def _section(title: str) -> str:
    start = README.index(f"\n## {title}\n")
    end = README.find("\n## ", start + 1)
    return README[start:end]


def test_first_lines_are_the_two_fresh_machine_commands():
    lines = README.splitlines()
    assert lines[0] == "```bash" and lines[3] == "```"
    demo, tests = lines[1], lines[2]
    assert "pip install -e ." in demo and "-m humimic.run scenarios/" in demo
    assert 'pip install -e ".[test' in tests and "-m pytest" in tests
    scenario = re.search(r"scenarios/(\S+\.yaml)", demo).group(1)
    assert (SCENARIOS_DIR / scenario).is_file()


def test_scenario_table_names_every_scenario():
    table = _section("Scenarios")
    named = set(re.findall(r"`([a-z0-9_]+)`", table))
    shipped = {p.stem for p in SCENARIOS_DIR.glob("*.yaml")}
    missing = sorted(shipped - named)
    assert not missing, f"scenarios missing from the README's table: {missing}"
    assert not {n for n in named if n.startswith(("ude_", "mimic_", "menezes_", "sugiyama_",
                                                 "schmidt_", "wearable_", "fig1"))} - shipped
