"""Turning pydantic validation errors into lines that name the field and the bad value."""

from __future__ import annotations

import difflib
from typing import Iterable

from pydantic import BaseModel, ValidationError


def error_lines(err: ValidationError, prefix: str = "", known: Iterable[str] = ()) -> list[str]:
    """One line per problem: ``prefix.field: message (got value)``; an unknown field gets
    the nearest of the ``known`` field names as a suggestion."""
    known = sorted(set(known))
    lines = []
    for e in err.errors():
        loc = ".".join([*([prefix] if prefix else []), *(str(x) for x in e["loc"])])
        shown = repr(e.get("input"))
        if len(shown) > 80:
            shown = shown[:77] + "..."
        hint = ""
        if e["type"] == "extra_forbidden" and e["loc"]:
            close = difflib.get_close_matches(str(e["loc"][-1]), known, n=1, cutoff=0.6)
            hint = f"; did you mean {close[0]!r}?" if close else ""
        lines.append(f"{loc or '(top level)'}: {e['msg']} (got {shown}){hint}")
    return lines


def field_names(model: type[BaseModel]) -> set[str]:
    """Every field name in a pydantic model and the models its fields hold, recursively."""
    from typing import get_args

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
