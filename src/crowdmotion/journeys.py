"""Journeys: when the agents of a group enter the scene (sources), shared by the methods.

A group may enter over time instead of all at once: at a rate, or at listed times. In a
scenario file::

    [[groups]]
    name = "commuters"
    count = 120
    spawn = { shape = "rect", lower = [0, 4], upper = [1, 8] }   # the entrance
    goal = { shape = "rect", lower = [38, 2], upper = [40, 10] }
    enter = { rate = 2.0, start = 5.0 }     # 2 persons/s from t = 5 s: the last at 64.5 s
    # enter = { times = [0, 0.5, 3, ...] }  # or one time per agent, seconds

and in Python ``Group(..., attributes={"enter": {"rate": 2.0}})``. Each agent gets a point
of the spawn region; when its time comes it enters there if no one stands within its body
of it, else it waits off-scene (not drawn, not avoided) and tries a fresh point of the
region at each step until there is room. The delay (entry time less the time it was due)
is reported per group. Without ``enter`` every agent starts at t = 0, as before.
"""

from __future__ import annotations

import numpy as np

ENTER_KEYS = ("rate", "start", "times")


def entry_times(spec, count: int, where: str = "enter") -> np.ndarray:
    """(count,) the time (s) each agent of a group is due to enter: ``start + k / rate``
    for k = 0 … count − 1, or the listed ``times``; zeros without a spec. ValueError
    naming ``where`` and the bad value otherwise."""
    if spec is None:
        return np.zeros(count)
    if not isinstance(spec, dict):
        raise ValueError(f"{where} must be a table: rate (persons/s) and start (s), or times (s), got {spec!r}")
    unknown = sorted(set(spec) - set(ENTER_KEYS))
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown}; expected rate and start, or times")
    if ("rate" in spec) == ("times" in spec):
        raise ValueError(f"{where}: give either rate (with an optional start) or times, got {spec!r}")
    if "times" in spec:
        if "start" in spec:
            raise ValueError(f"{where}: start goes with rate; times are absolute, got {spec!r}")
        try:
            times = np.asarray(spec["times"], dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{where}.times must be a list of seconds, got {spec['times']!r}") from None
        if times.shape != (count,):
            raise ValueError(f"{where}.times: {times.size} time(s) for a group of {count}: give one per agent")
        bad = np.flatnonzero(~np.isfinite(times) | (times < 0))
        if len(bad):
            raise ValueError(f"{where}.times.{int(bad[0])} must be a number of seconds >= 0, got {times[bad[0]]}")
        return times
    rate, start = _number(spec["rate"], f"{where}.rate"), _number(spec.get("start", 0.0), f"{where}.start")
    if rate <= 0:
        raise ValueError(f"{where}.rate must be a positive number of persons per second, got {spec['rate']!r}")
    return start + np.arange(count) / rate


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not np.isfinite(value) or value < 0:
        raise ValueError(f"{where} must be a finite number >= 0, got {value!r}")
    return float(value)


def entry_report(names: np.ndarray, due: np.ndarray, entered: np.ndarray) -> dict:
    """Per group: agents that entered, agents still waiting at the end, and the mean and
    longest delay (s) between being due and entering (for summary.json)."""
    out = {}
    for name in dict.fromkeys(names.tolist()):
        own = names == name
        ok = own & np.isfinite(entered)
        delay = entered[ok] - due[ok]
        out[str(name)] = {"entered": int(ok.sum()), "waiting_at_end": int((own & ~np.isfinite(entered)).sum()),
                          "mean_delay_s": float(delay.mean()) if ok.any() else None,
                          "max_delay_s": float(delay.max()) if ok.any() else None}
    return out
