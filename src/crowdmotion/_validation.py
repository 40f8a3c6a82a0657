"""Turning pydantic validation errors into lines that name the field and the bad value."""

from __future__ import annotations

import difflib
import math
import re
from typing import Annotated, Any, Callable, ClassVar, Iterable, get_args

from pydantic import BaseModel, Field, ValidationError

SHOWN_MAX = 80  # characters of a value shown in a message

# The largest coordinate, length or duration a scenario or a method's parameters may give:
# 1000 km (or 1e6 s). Beyond it grids cannot be allocated and squared distances overflow
# (a 1e300 m obstacle once covered nothing), so such values are refused by name.
MAX_MAGNITUDE = 1e6
Coordinate = Annotated[float, Field(ge=-MAX_MAGNITUDE, le=MAX_MAGNITUDE, allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, le=MAX_MAGNITUDE, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, le=MAX_MAGNITUDE, allow_inf_nan=False)]

# a message from a model-level check that names its own field: "groups.0.goal: ..."
_OWN_FIELD = re.compile(r"^([A-Za-z_][\w]*(?:\.[\w]+)*): (.*)$", re.S)


def id_range(count: int, things: str = "agents") -> str:
    """What a live API's error says of the ids there are: "ids run from 0 to 4", or "it
    has no agents yet" (``things``: what they number)."""
    return f"ids run from 0 to {count - 1}" if count > 0 else f"it has no {things} yet"


def shown(value: Any) -> str:
    """A value as a scenario file writes it (TOML): ``true``, ``'no'``, ``[1.0, 2]``, ``nan``;
    numpy scalars as plain numbers; cut to ``SHOWN_MAX`` characters."""

    def fmt(v: Any) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if hasattr(v, "item") and getattr(v, "ndim", 1) == 0:  # a numpy scalar
            v = v.item()
            if isinstance(v, bool):
                return "true" if v else "false"
        if isinstance(v, float):
            if math.isnan(v) or math.isinf(v):
                return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
            text = repr(v)  # the shortest that reads back, or 12 digits: 1e+12, not 1000000000000.0
            return text if len(text) <= 12 else format(v, ".12g")
        if isinstance(v, int):
            return str(v)
        if isinstance(v, str):  # 'text' is a TOML literal string too
            return repr(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(fmt(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {fmt(x)}" for k, x in v.items()) + " }" if v else "{}"
        if v is None:
            return "nothing"
        return repr(v)

    text = fmt(value)
    return text if len(text) <= SHOWN_MAX else text[: SHOWN_MAX - 3] + "..."


def _message(e: dict) -> str:
    """pydantic's message in a user's words: no "Value error, " prefix; strict types say
    what a scenario file must write."""
    msg = e["msg"]
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, "):]
    if msg.startswith("Assertion failed, "):
        msg = msg[len("Assertion failed, "):]
    kind, value = e["type"], e.get("input")
    if kind == "int_type" and isinstance(value, (bool, float)):
        msg = "must be a whole number" + (" (true and false are not numbers)" if isinstance(value, bool) else "")
    elif kind == "float_type" and isinstance(value, (bool, str)):
        msg = "must be a number" + (" (true and false are not numbers)" if isinstance(value, bool) else
                                    " (write it without quotes)")
    elif kind == "int_type" and isinstance(value, str):
        msg = "must be a whole number (write it without quotes)"
    elif kind == "bool_type":
        msg = "must be true or false (without quotes)"
    elif kind == "string_type":
        msg = "must be a string (in quotes)"
    elif kind == "missing":
        msg = "is missing: the scenario must give it"
    elif kind in _BOUNDS and e.get("ctx"):  # "Input should be greater than 0": pydantic's words for a bound
        words, key = _BOUNDS[kind]
        bound = e["ctx"].get(key)
        msg = f"must be {words} {shown(int(bound) if isinstance(bound, float) and bound.is_integer() else bound)}"
    elif kind == "finite_number":
        msg = "must be a finite number"
    elif kind == "union_tag_invalid" and e.get("ctx"):  # "Input tag 'ellipse' found using 'shape' does not match ..."
        ctx = e["ctx"]
        tags = [t.strip(" '") for t in str(ctx.get("expected_tags", "")).split(",") if t.strip(" '")]
        if e.get("loc") and e["loc"][-1] == "spawn":  # goal shapes only: a spawn cannot move or be the antipodes
            tags = [t for t in tags if t not in GOAL_ONLY_SHAPES]
        msg = f"{ctx.get('discriminator', 'shape').strip(chr(39))} {ctx.get('tag')!r} is not one of " + \
            ", ".join(repr(t) for t in tags)
    return msg


GOAL_ONLY_SHAPES = ("moving", "antipodal")  # region shapes a goal may take and a spawn may not


_BOUNDS = {"greater_than": ("more than", "gt"), "greater_than_equal": ("at least", "ge"),
           "less_than": ("less than", "lt"), "less_than_equal": ("at most", "le")}


def _models_in(tp) -> list[type[BaseModel]]:
    """The pydantic models an annotation holds: itself, or those of its unions, lists, options."""
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [tp]
    return [m for arg in get_args(tp) for m in _models_in(arg)]


def fields_at(model: type[BaseModel], loc: tuple) -> set[str]:
    """The field names of the table at ``loc`` (a pydantic error's location less its last
    key) under ``model``: ``("groups", 0)`` is a GroupSpec, ``("scene", "obstacles", 0,
    "box")`` a BoxSpec (a tagged union's member is named by its tag). Empty where the
    location cannot be followed."""
    here = [model]
    for key in loc:
        if isinstance(key, int):
            continue  # an item of a list: the list's own models
        if any(key in m.model_fields for m in here):
            here = [n for m in here if key in m.model_fields for n in _models_in(m.model_fields[key].annotation)]
            continue
        tagged = [m for m in here if any(key in get_args(f.annotation) for f in m.model_fields.values())]
        if not tagged:
            return set()
        here = tagged
    return {name for m in here for name in m.model_fields}


def error_lines(err: ValidationError, prefix: str = "", known: Iterable[str] = (),
                hint: Callable[[tuple, str], str | None] | None = None,
                model: type[BaseModel] | None = None) -> list[str]:
    """One line per problem: ``prefix.field: message (got value)``; an unknown field gets
    the nearest of the field names of its own table as a suggestion (``model``: the model
    the locations start from; without one, or where its table cannot be told, the nearest
    of the ``known`` field names), or what ``hint(loc, key)`` says about it (``loc``: the
    table holding the key) when that is not None."""
    known = sorted(set(known))
    lines = []
    for e in err.errors():
        path = [*([prefix] if prefix else []), *(str(x) for x in e["loc"])]
        msg = _message(e)
        got = f" (got {shown(e.get('input'))})"
        if e["type"] == "missing" or (isinstance(e.get("input"), dict) and e["type"] == "value_error"):
            got = ""  # the whole table the field is missing from, or a check that names its values
        if not e["loc"]:  # a check of the whole model: its message names the field itself
            m = _OWN_FIELD.match(msg)
            if m and ("." in m.group(1) or m.group(1) in known):
                path, msg = [*([prefix] if prefix else []), m.group(1)], m.group(2)
            got = ""
        loc = ".".join(path)
        extra = ""
        if e["type"] == "extra_forbidden" and e["loc"]:
            key = str(e["loc"][-1])
            said = hint(tuple(e["loc"][:-1]), key) if hint is not None else None
            if said is not None:
                msg, extra = said, ""
            else:
                if key in known:  # another table's or kind's field (a block's cols in a wedge)
                    msg = f"is not a field here ({key!r} belongs to another table or kind, not this one)"
                else:
                    # the table's own fields: a group's "speed" is not the scenario's "seed"
                    here = fields_at(model, tuple(e["loc"][:-1])) if model is not None else set()
                    close = difflib.get_close_matches(key, sorted(here) or known, n=1, cutoff=0.6)
                    msg = "is not a known field"
                    extra = f"; did you mean {close[0]!r}?" if close else ""
        lines.append(f"{loc or '(top level)'}: {msg}{got}{extra}")
    return lines


def field_names(model: type[BaseModel]) -> set[str]:
    """Every field name in a pydantic model and the models its fields hold, recursively."""
    seen: set[type] = set()
    names: set[str] = set()

    def walk(tp) -> None:
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            if tp in seen:
                return
            seen.add(tp)
            for name, f in tp.model_fields.items():
                names.add(name)
                walk(f.annotation)
        for arg in get_args(tp):
            walk(arg)

    walk(model)
    return names


class _SaysWhichField(type(BaseModel)):
    """The metaclass of :class:`MethodParams`: a call building parameters in Python turns
    pydantic's ValidationError into a ValueError in the user's terms. (Overriding
    ``__init__`` would do it too, but pydantic then calls that ``__init__`` while it
    validates a scenario file's method block, and the file's own hints, "belongs to
    [rvo]", were lost.)"""

    def __call__(cls, *args: Any, **data: Any):
        try:
            return super().__call__(*args, **data)
        except ValidationError as exc:
            raise ValueError("; ".join(error_lines(exc, cls.error_prefix, known=cls.model_fields))) from None


class MethodParams(BaseModel, metaclass=_SaysWhichField):
    """A method's parameters (RVOParams, MDPParams, PSOParams, FormationParams): built
    in Python, a bad field raises ValueError naming ``prefix.field`` and the value, one
    line each, with the nearest known field for a typo (``rvo.timestep: is not a known
    field (got 0.1); did you mean 'time_step'?``), not pydantic's error and its web
    address. ``model_validate`` keeps pydantic's ValidationError for callers that format
    it themselves."""

    error_prefix: ClassVar[str] = ""

