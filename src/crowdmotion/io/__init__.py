"""Trajectory files: one writer/reader per format, chosen by file suffix.

``.parquet`` and ``.csv`` (long form), ``.sqlite`` (JuPedSim v2, read by PedPy) and
``.usd`` / ``.usda`` / ``.usdc`` (Universal Scene Description). Every writer works from
Trajectories alone and writes atomically.
"""

from __future__ import annotations

from pathlib import Path

from crowdmotion.io import csv as _csv
from crowdmotion.io import parquet as _parquet
from crowdmotion.io import sqlite as _sqlite
from crowdmotion.io import usd as _usd

FORMATS = {".parquet": _parquet, ".csv": _csv, ".sqlite": _sqlite, ".usd": _usd, ".usda": _usd, ".usdc": _usd}


def _format(path: Path):
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(f"unknown trajectory format {path.suffix!r} for {path}; use one of {sorted(FORMATS)}")
    return fmt


def write_trajectories(traj, path) -> Path:
    """Write ``traj`` to ``path`` (format from the suffix), atomically."""
    path = Path(path)
    _format(path).write(traj, path)
    return path


def read_trajectories(path):
    """Read trajectories from ``path`` (format from the suffix)."""
    path = Path(path)
    fmt = _format(path)
    if not path.is_file():
        raise FileNotFoundError(f"no trajectory file at {path}")
    return fmt.read(path)
