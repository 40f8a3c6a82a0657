"""The generated scenario reference matches the schema the loader uses."""

import runpy
from pathlib import Path

DOCS = Path(__file__).parent.parent / "docs"


def test_scenario_reference_is_up_to_date():
    make = runpy.run_path(str(DOCS / "make_scenario_reference.py"))
    assert (DOCS / "scenario-reference.md").read_text() == make["render"](), \
        "docs/scenario-reference.md is stale: run python docs/make_scenario_reference.py"
