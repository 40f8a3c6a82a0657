"""Write docs/scenario-reference.md from the scenario schema itself (pydantic models), so
the reference can never drift from what the loader accepts.

    python docs/make_scenario_reference.py
"""

from __future__ import annotations

import inspect
import re
from pathlib import Path
from typing import Union, get_args, get_origin

from pydantic import BaseModel

from crowdmotion import scenario as S
from crowdmotion.formation import params as F
from crowdmotion.mdp import params as M
from crowdmotion.pso import params as P
from crowdmotion.rvo import params as R

OUT = Path(__file__).parent / "scenario-reference.md"
SECTIONS = [
    ("Top level", [S.ScenarioSpec]),
    ("[scene]", [S.SceneSpec, S.CircleSpec, S.SphereSpec, S.BoxSpec, S.PolygonSpec, S.PathSpec]),
    ("[[groups]]", [S.GroupSpec, S.PointRegion, S.PointsRegion, S.RectRegion, S.DiscRegion, S.MovingRegion,
                    S.RingRegion, S.AntipodalRegion]),
    ("Formation templates (a group's `formation` table)", [F.BlockTemplate, F.WedgeTemplate, F.CircleTemplate,
                                                          F.LineTemplate, F.CarsTemplate, F.PointsTemplate]),
    ("[mdp]", [M.MDPParams]),
    ("[rvo]", [R.RVOParams]),
    ("[pso]", [P.PSOParams, P.ObstacleField]),
    ("[formation]", [F.FormationParams]),
    ("[output]", [S.OutputSpec]),
]


def _type_name(tp) -> str:
    origin = get_origin(tp)
    if origin is None:
        return getattr(tp, "__name__", str(tp)).replace("NoneType", "none")
    args = [a for a in get_args(tp) if not isinstance(a, (int, float, str)) or origin.__name__ == "Literal"]
    if getattr(origin, "__name__", "") == "Literal" or str(origin).endswith("Literal"):
        return " \\| ".join(repr(a) for a in get_args(tp))
    if origin is Union or str(origin) == "types.UnionType":
        return " or ".join(_type_name(a) for a in args)
    if getattr(origin, "__name__", "") == "Annotated" or str(origin).endswith("Annotated"):
        return _type_name(get_args(tp)[0])
    return f"{getattr(origin, '__name__', str(origin))}[{', '.join(_type_name(a) for a in args)}]"


def _descriptions(model) -> dict[str, str]:
    """``field : type  text`` lines of the model's docstring (and their continuations)."""
    doc = model.__dict__.get("__doc__") or ""
    doc = inspect.cleandoc(doc)
    out, current = {}, None
    for line in doc.splitlines():
        m = re.match(r"^([a-z_][a-z0-9_, ]*?)\s*:\s*\S+(?:\s\|\s\S+)*\s{2,}(.*)$", line)
        if m:
            names = [n.strip() for n in m.group(1).split(",")]
            for n in names:
                out[n] = m.group(2).strip()
            current = names
        elif current and line.startswith(" ") and line.strip():
            for n in current:
                out[n] += " " + line.strip()
        else:
            current = None
    return out


def _constraints(field) -> str:
    parts = []
    for meta in field.metadata:
        for attr, sym in (("gt", ">"), ("ge", "≥"), ("lt", "<"), ("le", "≤"), ("min_length", "min length"),
                          ("max_length", "max length")):
            v = getattr(meta, attr, None)
            if v is not None:
                parts.append(f"{sym} {v}")
    return ", ".join(parts)


def table(model: type[BaseModel]) -> str:
    desc = _descriptions(model)
    own = model.__dict__.get("__doc__") or ""
    first = inspect.cleandoc(own).split("\n\n")[0].replace("\n", " ") if own else ""
    rows = [f"**{model.__name__}**" + (f" — {first}" if first else ""), "", "| field | type | default | constraints | meaning |",
            "|---|---|---|---|---|"]
    for name, f in model.model_fields.items():
        value = None if f.is_required() else f.get_default(call_default_factory=True)
        default = "required" if f.is_required() else ("its own table below" if isinstance(value, BaseModel)
                                                      else repr(value))
        type_name = _type_name(f.annotation)
        tp = type_name if "\\|" in type_name else type_name.replace("|", "\\|")
        rows.append(f"| `{name}` | {tp} | `{default}` | {_constraints(f)} | {desc.get(name, '')} |")
    return "\n".join(rows) + "\n"


def render() -> str:
    """The whole reference page."""
    parts = ["# Scenario file reference", "",
             "Generated from the schema by `python docs/make_scenario_reference.py`; the loader accepts exactly "
             "this. Unknown fields are errors; every error names the field and the value.", ""]
    for title, models in SECTIONS:
        parts += [f"## {title}", ""]
        for m in models:
            parts += [table(m), ""]
    return "\n".join(parts)


def main() -> None:
    OUT.write_text(render())
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
