"""The docs hold: the generated scenario reference matches the schema the loader uses,
and the Python examples a user copies from the README and the method pages run as
written."""

import re
import runpy
from pathlib import Path

import pytest

DOCS = Path(__file__).parent.parent / "docs"
# pages whose examples run top to bottom on their own (the others show fragments of a run)
RUNNABLE = ("README.md", "getting-started.md", "rvo.md", "formation.md", "pso.md")


def test_scenario_reference_is_up_to_date():
    make = runpy.run_path(str(DOCS / "make_scenario_reference.py"))
    assert (DOCS / "scenario-reference.md").read_text() == make["render"](), \
        "docs/scenario-reference.md is stale: run python docs/make_scenario_reference.py"


@pytest.mark.parametrize("page", RUNNABLE)
def test_the_python_examples_of_a_page_run_as_written(page, tmp_path, monkeypatch):
    path = DOCS.parent / page if page == "README.md" else DOCS / page
    code = "\n".join(re.findall(r"```python\n(.*?)```", path.read_text(), re.S))
    assert code, f"{page} has no Python example"
    monkeypatch.chdir(tmp_path)  # whatever an example writes lands here
    exec(compile(code, str(path), "exec"), {"__name__": "__example__"})


def test_the_whole_scenarios_a_page_shows_load_as_written():
    """A TOML block with a method and a scene is a whole scenario a user may save and run;
    the others are fragments of one (a group's table, a method's parameters)."""
    from crowdmotion.scenario import parse_scenario

    whole = [(page.name, block) for page in sorted(DOCS.glob("*.md"))
             for block in re.findall(r"```toml\n(.*?)```", page.read_text(), re.S)
             if re.search(r"^method\s*=", block, re.M) and re.search(r"^\[scene\]", block, re.M)]
    assert len(whole) >= 4
    for name, block in whole:
        parse_scenario(block, f"docs/{name}")


def test_the_pedpy_sections_setting_for_measurement_writes_the_steps_as_simulated():
    """docs/exporting.md tells a researcher measuring with PedPy which RVO setting makes
    the trajectory file hold the steps as simulated rather than the relaxed paths."""
    import textwrap
    import tomllib

    from crowdmotion.rvo.adapter import output_copy
    from crowdmotion.rvo.params import RVOParams

    section = (DOCS / "exporting.md").read_text().split("## Pedestrian analysis with PedPy")[1].split("\n## ")[0]
    block = re.search(r"```toml\n(.*?)```", section, re.S).group(1)
    settings = tomllib.loads(textwrap.dedent(block))["rvo"]
    assert output_copy(RVOParams())  # the default: the file holds the steps relaxed
    assert not output_copy(RVOParams(**settings))
