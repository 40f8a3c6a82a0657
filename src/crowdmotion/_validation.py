"""Turning pydantic validation errors into lines that name the field and the bad value."""

from __future__ import annotations

from pydantic import ValidationError


def error_lines(err: ValidationError, prefix: str = "") -> list[str]:
    """One line per problem: ``prefix.field: message (got value)``."""
    lines = []
    for e in err.errors():
        loc = ".".join([*([prefix] if prefix else []), *(str(x) for x in e["loc"])])
        shown = repr(e.get("input"))
        if len(shown) > 80:
            shown = shown[:77] + "..."
        lines.append(f"{loc or '(top level)'}: {e['msg']} (got {shown})")
    return lines
