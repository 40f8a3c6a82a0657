"""Trajectory files: one writer/reader per format, chosen by file suffix.

``.parquet`` and ``.csv`` (long form), ``.sqlite`` (JuPedSim v2, read by PedPy) and
``.usd`` / ``.usda`` / ``.usdc`` (Universal Scene Description). Every writer works from
Trajectories alone and writes atomically.
"""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np

# suffix -> the module that reads and writes it, imported on first use (pyarrow alone
# takes 0.2 s to import: `validate`, which only needs the atomic writes, does without)
FORMATS = {".parquet": "parquet", ".csv": "csv", ".sqlite": "sqlite", ".usd": "usd", ".usda": "usd", ".usdc": "usd"}


def _format(path: Path):
    name = FORMATS.get(path.suffix.lower())
    if name is None:
        raise ValueError(f"unknown trajectory format {path.suffix!r} for {path}; use one of {sorted(FORMATS)}")
    return importlib.import_module(f"crowdmotion.io.{name}")


def write_trajectories(traj, path, **options) -> Path:
    """Write ``traj`` to ``path`` (format from the suffix), atomically, with its
    locomotion channels (:mod:`crowdmotion.locomotion`).

    ``options`` go to the format's writer: every format takes ``locomotion`` (a
    :class:`~crowdmotion.locomotion.LocomotionParams`); USD also takes
    ``prototype_up`` and ``prototype_forward`` (see :func:`crowdmotion.io.usd.write`).
    """
    path = Path(path)
    _format(path).write(traj, path, **options)
    return path


def read_locomotion(path):
    """The locomotion channels a trajectory file holds, as a
    :class:`~crowdmotion.locomotion.Locomotion` (format from the suffix)."""
    path = Path(path)
    fmt = _format(path)
    if not path.is_file():
        raise FileNotFoundError(f"no trajectory file at {path}")
    return fmt.read_locomotion(path)


def read_trajectories(path):
    """Read trajectories from ``path`` (format from the suffix); a file that could not
    be used (see :func:`check_read`) is refused with a ValueError naming it."""
    path = Path(path)
    fmt = _format(path)
    if not path.is_file():
        raise FileNotFoundError(f"no trajectory file at {path}")
    traj = fmt.read(path)
    check_read(traj, path)
    return traj


def check_read(traj, path: Path) -> None:
    """Refuse, naming the file, trajectories read from ``path`` that have no frames, an
    active agent at a NaN or infinite position, or a radius that is negative, NaN or
    infinite, or zero beside others' positive ones (every radius 0: the file gives none,
    as a Trajectories made without radii, or a JuPedSim file of its own, writes)."""
    from crowdmotion.geometry import require_finite_agents

    if traj.n_frames == 0:
        raise ValueError(f"{path}: the trajectory file has no frames")
    try:
        require_finite_agents({"positions": traj.positions}, traj.active_mask, ids=traj.ids)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    r = traj.radius
    bad = ~np.isfinite(r) | (r < 0) | ((r == 0) & (r > 0).any())
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"{path}: radius of agent {traj.ids[i]} is {r[i]}: radii must be positive metres")
