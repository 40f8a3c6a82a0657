"""Group colours shared by every picture, the player and the USD export's displayColor."""

from __future__ import annotations

from matplotlib import colormaps
from matplotlib.colors import is_color_like, to_rgba


def group_colours(names) -> dict:
    """A colour (RGBA) per group: the group's own name when it names a colour ("red",
    "blue"), else the next of matplotlib's tab10 colours not taken by such a name."""
    names = list(dict.fromkeys(names))
    tab10 = colormaps["tab10"]
    cycle = (tab10(i % 10) for i in range(10**6))
    own = {n: to_rgba(n) for n in names if isinstance(n, str) and is_color_like(n)}
    taken = set(own.values())
    out = {}
    for n in names:
        if n in own:
            out[n] = own[n]
            continue
        c = next(cycle)
        while c in taken:
            c = next(cycle)
        out[n] = c
    return out
