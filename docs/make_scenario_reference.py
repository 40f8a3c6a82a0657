"""Write docs/scenario-reference.md from the scenario schema itself (pydantic models), so
the reference can never drift from what the loader accepts.

    python docs/make_scenario_reference.py
"""

from __future__ import annotations

import inspect
import re
import types
import warnings
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
                    S.RingRegion, S.LatticeRegion, S.AntipodalRegion, S.EnterSpec]),
    ("Route stages (a group's `[[groups.route]]` tables, in order; see docs/journeys.md)",
     [S.GotoStageSpec, S.WaitStageSpec, S.WaitTimeSpec, S.QueueStageSpec, S.ChooseStageSpec, S.LeaveStageSpec]),
    ("Group attributes (a group's `attributes` table: rvo and formation; mdp and pso take none)",
     [R.RVOAttributes, F.FormationAttributes]),
    ("Formation templates (a group's `formation` table)", [F.BlockTemplate, F.WedgeTemplate, F.CircleTemplate,
                                                          F.LineTemplate, F.CarsTemplate, F.PointsTemplate]),
    ("[mdp]", [M.MDPParams]),
    ("[rvo]", [R.RVOParams]),
    ("[pso]", [P.PSOParams, P.ObstacleField]),
    ("[formation]", [F.FormationParams]),
    ("[output]", [S.OutputSpec]),
]


def _type_name(tp) -> str:
    """A type in the scenario file's own (TOML) terms."""
    origin = get_origin(tp)
    if origin is None:
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            return f"table ({tp.__name__})"
        return {"float": "number", "int": "integer", "str": "string", "bool": "true or false",
                "NoneType": "none", "Any": "any"}.get(getattr(tp, "__name__", str(tp)), getattr(tp, "__name__", str(tp)))
    args = get_args(tp)
    name = getattr(origin, "__name__", str(origin))
    if name == "Literal" or str(origin).endswith("Literal"):
        return " \\| ".join(repr(a) for a in args)
    if origin is Union or origin is types.UnionType:
        models = [a.__name__ for a in args if isinstance(a, type) and issubclass(a, BaseModel)]
        rest = [_type_name(a) for a in args if not (isinstance(a, type) and issubclass(a, BaseModel))]
        if len(models) > 1:
            tables = f"table ({', '.join(models[:-1])} or {models[-1]})"
            return " or ".join([tables, *rest])
        return " or ".join(_type_name(a) for a in args)
    if name == "Annotated" or str(origin).endswith("Annotated"):
        return _type_name(args[0])
    if origin is list:
        inner = _type_name(args[0])
        if inner.startswith("table"):
            return f"array of {inner.replace('table', 'tables', 1)}"
        return {"number": "array of numbers", "array of numbers": "array of points"}.get(inner, f"array of {inner}")
    if origin is dict:
        return "table"
    return f"{name}[{', '.join(_type_name(a) for a in args)}]"


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
    metas = list(field.metadata)
    if not metas:  # an optional value (``Fps | None``): the bounds sit on the union's annotated member
        import types
        import typing
        from typing import get_args, get_origin

        union = get_origin(field.annotation) in (typing.Union, types.UnionType)
        for arg in get_args(field.annotation) if union else ():
            for meta in getattr(arg, "__metadata__", ()):
                metas += list(getattr(meta, "metadata", [meta]))  # a Field(...) holds its bounds in metadata
    for meta in metas:
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
        tp = _type_name(f.annotation)
        rows.append(f"| `{name}` | {tp} | `{default}` | {_constraints(f)} | {desc.get(name, '')} |")
    return "\n".join(rows) + "\n"


# ---- which shapes each method takes: found by asking each method, not written down ----------
PROBE = """
method = "{method}"
[scene]
bounds = {bounds}
obstacles = [{obstacle}]
[[groups]]
name = "g"
count = 4
spawn = {spawn}
goal = {goal}
{extra}
"""
OBSTACLES = {
    "circle": (2, '{ shape = "circle", center = [20, 10], radius = 2 }'),
    "sphere": (3, '{ shape = "sphere", center = [20, 10, 10], radius = 2 }'),
    "box": (2, '{ shape = "box", lower = [18, 8], upper = [22, 12] }'),
    "polygon": (2, '{ shape = "polygon", vertices = [[18, 8], [22, 8], [20, 12]] }'),
    "moving (path)": (2, '{ shape = "circle", center = [20, 10], radius = 1, '
                         'path = { times = [0, 20], positions = [[20, 10], [20, 16]] } }'),
}
SPAWNS = {
    "point": '{ shape = "point", position = [5, 10] }',
    "points": '{ shape = "points", points = [[4, 8], [4, 12], [6, 8], [6, 12]] }',
    "rect": '{ shape = "rect", lower = [2, 5], upper = [8, 15] }',
    "disc": '{ shape = "disc", center = [5, 10], radius = 3 }',
    "ring": '{ shape = "ring", center = [5, 10], radius = 2 }',
    "lattice": '{ shape = "lattice", lower = [2, 5], upper = [8, 15] }',
}
GOALS = {
    "point": '{ shape = "point", position = [35, 10] }',
    "points": '{ shape = "points", points = [[34, 8], [34, 12], [36, 8], [36, 12]] }',
    "rect": '{ shape = "rect", lower = [32, 5], upper = [38, 15] }',
    "disc": '{ shape = "disc", center = [35, 10], radius = 3 }',
    "moving": '{ shape = "moving", times = [0, 30], positions = [[30, 10], [35, 12]] }',
    "antipodal": '{ shape = "antipodal", center = [20, 10] }',
}
METHODS = ("mdp", "rvo", "pso", "formation")
EXIT = '{ shape = "rect", lower = [38, 8], upper = [40, 12] }'
ROUTES = {  # one route per stage kind, each ending at an exit
    "goto": f'route = [{{ kind = "goto", area = {GOALS["disc"]} }}, {{ kind = "leave", area = {EXIT} }}]',
    "wait": f'route = [{{ kind = "wait", time = 2 }}, {{ kind = "leave", area = {EXIT} }}]',
    "queue": 'route = [{ kind = "queue", head = [30, 10], direction = [-1, 0], rate = 1 }, '
             f'{{ kind = "leave", area = {EXIT} }}]',
    "choose": f'route = [{{ kind = "choose", by = "nearest", among = [{{ kind = "leave", area = {EXIT} }}, '
              '{ kind = "leave", area = { shape = "rect", lower = [38, 0], upper = [40, 4] } }] }]',
    "leave": f'route = [{{ kind = "leave", area = {EXIT} }}]',
}


def _accepts(method: str, dim: int = 2, obstacle: str = "", spawn: str = SPAWNS["rect"],
             goal: str = GOALS["point"], route: str = "") -> bool:
    """Whether loading (which runs the method's own checks) accepts such a scenario."""
    bounds = "[[0, 0], [40, 20]]" if dim == 2 else "[[0, 0, 0], [40, 20, 20]]"
    if dim == 3:
        spawn = spawn.replace("[2, 5]", "[2, 5, 5]").replace("[8, 15]", "[8, 15, 15]")
        goal = goal.replace("[35, 10]", "[35, 10, 10]")
    group_extra = 'formation = { kind = "block", rows = 2, cols = 2, spacing = 1.2 }' \
        if method == "formation" and '"points"' not in spawn else ""
    text = PROBE.format(method=method, bounds=bounds, obstacle=obstacle, spawn=spawn, goal=goal,
                        extra=group_extra + "\n" + route)
    try:
        with warnings.catch_warnings():  # e.g. PSO's speed note: accepted is accepted
            warnings.simplefilter("ignore")
            S.parse_scenario(text)
    except (S.ScenarioError, ValueError):
        return False
    return True


def support() -> str:
    """The support table: each obstacle, spawn and goal shape against each method."""
    rows = ["| shape | " + " | ".join(METHODS) + " |", "|---|" + "---|" * len(METHODS)]
    mark = {True: "yes", False: "—"}
    for name, (dim, ob) in OBSTACLES.items():
        rows.append(f"| obstacle `{name}` | " + " | ".join(mark[_accepts(m, dim, ob)] for m in METHODS) + " |")
    for name, sp in SPAWNS.items():
        rows.append(f"| spawn `{name}` | " + " | ".join(mark[_accepts(m, spawn=sp)] for m in METHODS) + " |")
    for name, g in GOALS.items():
        sp = SPAWNS["ring"] if name == "antipodal" else SPAWNS["rect"]
        rows.append(f"| goal `{name}` | " + " | ".join(mark[_accepts(m, spawn=sp, goal=g)] for m in METHODS) + " |")
    rows.append("| 3D scene | " + " | ".join(mark[_accepts(m, 3)] for m in METHODS) + " |")
    for name, route in ROUTES.items():
        rows.append(f"| route stage `{name}` | " + " | ".join(mark[_accepts(m, route=route)] for m in METHODS) + " |")
    return "\n".join(rows) + "\n"


def personality_names() -> str:
    from crowdmotion.rvo.personality import TABLE4

    return ", ".join(f"`{k}`" for k in TABLE4)


def render() -> str:
    """The whole reference page."""
    parts = ["# Scenario file reference", "",
             "Generated from the schema by `python docs/make_scenario_reference.py`; the loader accepts exactly "
             "this, with strict types: a whole number where an integer is asked for (not `4.0` or `true`), "
             "`true` or `false` for a switch (not `\"no\"` or `1`). Unknown fields are errors, and so are "
             "another method's fields (its parameter table, a group's `personality` or `formation`, its "
             "attributes); every error names the field and the value. Every coordinate, length and duration is "
             "a finite number of at most 1,000,000 (metres or seconds) in size.", ""]
    parts += ["## What each method takes", "",
              "Found by loading a small scenario of each kind with each method (the loader runs the method's "
              "own checks), so it cannot drift from the code. \"—\" means `validate` refuses it with a "
              "message that says why.", "", support(), "",
              f"RVO personalities (a group's `personality`): the poles {personality_names()} (Table 4 of paper "
              "004), a list of five traits [O, C, E, A, N] each in [-1, 1], or a distribution table "
              "(see docs/rvo.md).", ""]
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
