"""Trajectory files: one writer/reader per format, chosen by file suffix.

``.parquet`` and ``.csv`` (long form), ``.sqlite`` (JuPedSim v2, read by PedPy) and
``.usd`` / ``.usda`` / ``.usdc`` (Universal Scene Description). Every writer works from
Trajectories alone and writes atomically.
"""

from __future__ import annotations

import importlib
from pathlib import Path

# suffix -> the module that reads and writes it, imported on first use (pyarrow alone
# takes 0.2 s to import: `validate`, which only needs the atomic writes, does without)
FORMATS = {".parquet": "parquet", ".csv": "csv", ".sqlite": "sqlite", ".usd": "usd", ".usda": "usd", ".usdc": "usd"}


def _format(path: Path):
    name = FORMATS.get(path.suffix.lower())
    if name is None:
        raise ValueError(f"unknown trajectory format {path.suffix!r} for {path}; use one of {sorted(FORMATS)}")
    return importlib.import_module(f"crowdmotion.io.{name}")


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
