"""Group colours shared by every picture, the player and the USD export's displayColor."""

from __future__ import annotations

from matplotlib import colormaps
from matplotlib.colors import is_color_like, to_rgba


def _palette():
    """Colours in the order groups take them: matplotlib's tab10, then the ten lighter
    shades of tab20, then turbo's hues, spread ever finer, so that no two of the first
    twenty groups share a colour (a floor of 12 rooms drew rooms 11 and 12 as 1 and 2)."""
    yield from (colormaps["tab10"](i) for i in range(10))
    yield from (colormaps["tab20"](i) for i in range(1, 20, 2))
    turbo, k = colormaps["turbo"], 2
    while True:
        yield from (turbo(j / k) for j in range(1, k, 2))
        k *= 2


def group_colours(names) -> dict:
    """A colour (RGBA) per group: the group's own name when it names a colour ("red",
    "blue"), else the next of :func:`_palette`'s colours (tab10's first) not taken by
    such a name."""
    names = list(dict.fromkeys(names))
    cycle = _palette()
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
