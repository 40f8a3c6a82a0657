"""CSV trajectory files: the long-form table; metadata goes to a ``.meta.json`` sidecar."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.csv as pacsv

from crowdmotion.io.atomic import atomic_path
from crowdmotion.io.longform import from_table, locomotion_from_table, metadata_json, to_table
from crowdmotion.locomotion import LocomotionParams


def sidecar(path: Path) -> Path:
    return path.with_name(path.name + ".meta.json")


def write(traj, path: Path, locomotion: LocomotionParams | None = None) -> None:
    """Write ``traj`` and its locomotion channels (derived with ``locomotion``'s
    parameters, the defaults when None) to ``path``, atomically."""
    loco = traj.locomotion(locomotion)  # derived once per run: every file shares them
    table = to_table(traj, loco)
    with atomic_path(path) as tmp:
        pacsv.write_csv(table, tmp)
    with atomic_path(sidecar(path)) as tmp:
        tmp.write_text(metadata_json(traj, loco))


def read(path: Path):
    try:
        table = pacsv.read_csv(path)
    except Exception as exc:
        raise ValueError(f"{path} is not a readable trajectory CSV: {exc}") from exc
    meta = {}
    if sidecar(path).is_file():
        meta = json.loads(sidecar(path).read_text())
    return from_table(table, meta)


def read_locomotion(path: Path):
    """The locomotion channels written into ``path`` (a :class:`~crowdmotion.locomotion.Locomotion`)."""
    try:
        table = pacsv.read_csv(path)
    except Exception as exc:
        raise ValueError(f"{path} is not a readable trajectory CSV: {exc}") from exc
    meta = json.loads(sidecar(path).read_text()) if sidecar(path).is_file() else {}
    return locomotion_from_table(table, meta)
