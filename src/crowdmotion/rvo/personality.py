"""OCEAN personalities and their RVO parameters (Huang & Liu 2012, §3 and §5.2, Table 4).

A personality is a vector ψ = ⟨ψO, ψC, ψE, ψA, ψN⟩ with each ψk in [−1, 1] (eq. 1);
−1 is the negative pole at its strongest. The dominant dimension f(ψ) picks a row of
Table 4 and the intensity |ψk| blends linearly from the neutral set (the mid-point of the
trait's two poles) to that pole. The blend moves every parameter in the direction eq. (4)
gives (e.g. O+: M and D grow with ψO, w shrinks), and reproduces Table 4 exactly at |ψk| = 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Mapping, Sequence

import numpy as np

TRAITS = ("O", "C", "E", "A", "N")

# Table 4: pole -> (M = max neighbours, D = neighbour distance [m], N_sample, w = safety)
TABLE4: dict[str, tuple[int, float, int, float]] = {
    "O+": (15, 15.0, 50, 3.0),
    "O-": (10, 5.0, 50, 7.5),
    "C+": (20, 20.0, 50, 1.0),
    "C-": (5, 5.0, 50, 7.5),
    "E+": (10, 10.0, 50, 4.0),
    "E-": (5, 5.0, 50, 6.0),
    "A+": (10, 10.0, 50, 7.5),
    "A-": (5, 5.0, 50, 3.0),
    "N+": (10, 2.5, 25, 3.0),
    "N-": (5, 5.0, 25, 7.5),
}

PARAM_KEYS = ("max_neighbors", "neighbor_dist", "samples", "safety")

DominantRule = Literal["abs", "max"]


def _pole_name(name: str) -> str:
    """Normalise 'O+', 'o-', 'O−' (Unicode minus) to the TABLE4 key, or raise naming it."""
    key = str(name).strip().upper().replace("\u2212", "-")
    if key not in TABLE4:
        raise ValueError(f"unknown personality trait {name!r}; expected one of {sorted(TABLE4)} or 5 numbers in [-1, 1]")
    return key


def check_vector(psi, what: str = "personality") -> np.ndarray:
    """An OCEAN vector as a (5,) float array; raises naming the bad entry."""
    try:
        v = np.asarray(psi, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a trait name like 'O+' or 5 numbers in [-1, 1], got {psi!r}") from None
    if v.shape != (5,):
        raise ValueError(f"{what} must have 5 numbers (O, C, E, A, N), got shape {v.shape}: {psi!r}")
    for k, x in zip(TRAITS, v):
        if not np.isfinite(x) or abs(x) > 1.0:
            raise ValueError(f"{what}: ψ{k} must lie in [-1, 1], got {float(x)!r}")
    return v


def trig_generator(theta) -> np.ndarray:
    """ψk = sign(θ)·(1 − cos θ) for θ in [−π/2, π/2]: the paper's eq. (2) mapped onto [−1, 1].

    The paper writes ψk = −cos θ + 1, which only spans [0, 1]; the sign makes the
    negative half of θ give the negative pole, as SPEC §5 decides.
    """
    th = np.asarray(theta, dtype=float)
    if np.any(~np.isfinite(th)) or np.any(np.abs(th) > np.pi / 2 + 1e-12):
        raise ValueError(f"θ must lie in [-π/2, π/2], got {theta!r}")
    return np.sign(th) * (1.0 - np.cos(th))


@dataclass(frozen=True)
class Dominant:
    """The dominant dimension of a personality: trait letter, pole sign and intensity |ψk|."""

    trait: str
    sign: int
    intensity: float

    @property
    def pole(self) -> str:
        return f"{self.trait}{'+' if self.sign > 0 else '-'}"


def dominant_trait(psi, rule: DominantRule = "abs") -> Dominant:
    """f(ψ): the dimension that drives behaviour.

    ``rule="abs"`` (default) takes the largest |ψk|; ``rule="max"`` is the paper's literal
    f(ψ) = max ψk (§6), which ignores strong negative poles when any ψk is larger. Ties go
    to the first trait in O, C, E, A, N order. A zero ψk counts as the positive pole.
    """
    v = check_vector(psi)
    if rule == "abs":
        k = int(np.argmax(np.abs(v)))
    elif rule == "max":
        k = int(np.argmax(v))
    else:
        raise ValueError(f"dominant rule must be 'abs' or 'max', got {rule!r}")
    return Dominant(TRAITS[k], 1 if v[k] >= 0 else -1, float(abs(v[k])))


def _opposite(pole: str) -> str:
    return pole[0] + ("-" if pole[1] == "+" else "+")


def blend(pole: str, intensity: float) -> dict:
    """Parameters for ``pole`` at ``intensity`` in [0, 1]: neutral + intensity·(pole − neutral).

    M and N_sample are rounded to whole numbers (half up); at intensity 1 the result is
    Table 4's row exactly.
    """
    pole = _pole_name(pole)
    if not (0.0 <= intensity <= 1.0):
        raise ValueError(f"personality intensity must lie in [0, 1], got {intensity!r}")
    hi = np.array(TABLE4[pole], dtype=float)
    neutral = (hi + np.array(TABLE4[_opposite(pole)], dtype=float)) / 2.0
    val = neutral + intensity * (hi - neutral)
    if intensity == 1.0:
        val = hi
    return {
        "max_neighbors": int(np.floor(val[0] + 0.5)),
        "neighbor_dist": float(val[1]),
        "samples": int(np.floor(val[2] + 0.5)),
        "safety": float(val[3]),
    }


def personality_params(trait, rule: DominantRule = "abs") -> dict:
    """RVO parameters for a personality (paper Table 4 and eq. (4)).

    Parameters
    ----------
    trait : str or sequence of 5 floats
        A pole name (``"O+"``, ``"C-"``, ...) meaning that pole at full strength, or an
        OCEAN vector ⟨ψO, ψC, ψE, ψA, ψN⟩ with entries in [−1, 1].
    rule : "abs" or "max"
        How the dominant dimension is chosen (see :func:`dominant_trait`).

    Returns
    -------
    dict with keys ``max_neighbors`` (M), ``neighbor_dist`` (D, metres), ``samples``
    (N_sample) and ``safety`` (w in eq. (3)).
    """
    if isinstance(trait, str):
        return blend(trait, 1.0)
    d = dominant_trait(trait, rule)
    return blend(d.pole, d.intensity)


def sample_personalities(spec, count: int, rng: np.random.Generator, what: str = "personality") -> np.ndarray:
    """(count, 5) OCEAN vectors from a group's personality spec.

    ``spec`` is a pole name (every agent that pole at full strength), a 5-vector (every
    agent the same), ``(count, 5)`` vectors (one per agent), or a mapping with
    ``distribution``:

    - ``"trig"``: θk ~ U(theta_low[k], theta_high[k]) within [−π/2, π/2], ψk by eq. (2)
      mapped to [−1, 1] (:func:`trig_generator`);
    - ``"uniform"``: ψk ~ U(low[k], high[k]);
    - ``"normal"``: ψk ~ N(mean[k], std[k]) clipped to [−1, 1].
    """
    if isinstance(spec, str):
        pole = _pole_name(spec)
        v = np.zeros(5)
        v[TRAITS.index(pole[0])] = 1.0 if pole[1] == "+" else -1.0
        return np.tile(v, (count, 1))
    if isinstance(spec, Mapping):
        return _sample_distribution(dict(spec), count, rng, what)
    if np.ndim(spec) == 2:
        rows = np.array([check_vector(v, f"{what}[{i}]") for i, v in enumerate(spec)]).reshape(-1, 5)
        if len(rows) != count:
            raise ValueError(f"{what} must be one OCEAN vector or ({count}, 5) vectors, got {len(rows)} rows")
        return rows
    return np.tile(check_vector(spec, what), (count, 1))


def _five(spec: dict, key: str, what: str, default=None) -> np.ndarray:
    if key not in spec:
        if default is None:
            raise ValueError(f"{what}: distribution {spec.get('distribution')!r} needs {key!r} (5 numbers)")
        return np.full(5, default, dtype=float)
    try:
        v = np.asarray(spec[key], dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what}.{key} must be 5 numbers, got {spec[key]!r}") from None
    if v.shape != (5,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what}.{key} must be 5 finite numbers (O, C, E, A, N), got {spec[key]!r}")
    return v


def _sample_distribution(spec: dict, count: int, rng: np.random.Generator, what: str) -> np.ndarray:
    kind = spec.get("distribution")
    allowed = {"trig": {"theta_low", "theta_high"}, "uniform": {"low", "high"}, "normal": {"mean", "std"}}
    if kind not in allowed:
        raise ValueError(f"{what}.distribution must be one of {sorted(allowed)}, got {kind!r}")
    extra = set(spec) - allowed[kind] - {"distribution"}
    if extra:
        raise ValueError(f"{what}: unknown keys {sorted(extra)} for distribution {kind!r}")
    if kind == "trig":
        lo = _five(spec, "theta_low", what, -np.pi / 2)
        hi = _five(spec, "theta_high", what, np.pi / 2)
        if np.any(np.abs(lo) > np.pi / 2 + 1e-12) or np.any(np.abs(hi) > np.pi / 2 + 1e-12) or np.any(hi < lo):
            raise ValueError(f"{what}: need -π/2 <= theta_low <= theta_high <= π/2, got {lo.tolist()}, {hi.tolist()}")
        return trig_generator(np.clip(rng.uniform(lo, hi, size=(count, 5)), -np.pi / 2, np.pi / 2))
    if kind == "uniform":
        lo, hi = _five(spec, "low", what), _five(spec, "high", what)
        if np.any(lo < -1) or np.any(hi > 1) or np.any(hi < lo):
            raise ValueError(f"{what}: need -1 <= low <= high <= 1, got {lo.tolist()}, {hi.tolist()}")
        return rng.uniform(lo, hi, size=(count, 5))
    mean, std = _five(spec, "mean", what), _five(spec, "std", what)
    if np.any(np.abs(mean) > 1) or np.any(std < 0):
        raise ValueError(f"{what}: need mean in [-1, 1] and std >= 0, got {mean.tolist()}, {std.tolist()}")
    return np.clip(rng.normal(mean, std, size=(count, 5)), -1.0, 1.0)


def params_for_vectors(psi: np.ndarray, rule: DominantRule = "abs") -> dict[str, np.ndarray]:
    """Per-agent parameter arrays for a (N, 5) stack of OCEAN vectors."""
    rows = [personality_params(v, rule) for v in np.asarray(psi, dtype=float)]
    return {k: np.array([r[k] for r in rows]) for k in PARAM_KEYS}


def describe(psi: Sequence[float], rule: DominantRule = "abs") -> str:
    """'O+ 0.80' style label of a personality's dominant pole and intensity."""
    d = dominant_trait(psi, rule)
    return f"{d.pole} {d.intensity:.2f}"


def personality_metadata(psi: np.ndarray) -> dict:
    """The run's metadata entry for its agents' personalities: ``{"personality": (N, 5)
    rows}`` where any agent has one (rows of agents without one are NaN: null in JSON),
    nothing where none has (a crowd without personalities wrote a row of five nulls per
    agent into every export's metadata)."""
    psi = np.asarray(psi, dtype=float)
    return {"personality": psi.tolist()} if np.isfinite(psi).any() else {}
