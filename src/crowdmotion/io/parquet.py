"""Parquet trajectory files: the long-form table with the metadata in the schema."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq

from crowdmotion.io.atomic import atomic_path
from crowdmotion.io.longform import from_table, locomotion_from_table, metadata_json, to_table
from crowdmotion.locomotion import LocomotionParams

_KEY = b"crowdmotion"


def write(traj, path: Path, locomotion: LocomotionParams | None = None) -> None:
    """Write ``traj`` and its locomotion channels (derived with ``locomotion``'s
    parameters, the defaults when None) to ``path``, atomically."""
    loco = traj.locomotion(locomotion)  # derived once per run: every file shares them
    table = to_table(traj, loco)
    table = table.replace_schema_metadata({_KEY: metadata_json(traj, loco).encode()})
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp, compression="zstd")


def read(path: Path):
    try:
        table = pq.read_table(path)
    except Exception as exc:  # pyarrow raises several types for corrupt files
        raise ValueError(f"{path} is not a readable Parquet file: {exc}") from exc
    meta = (table.schema.metadata or {}).get(_KEY)
    return from_table(table, json.loads(meta) if meta else {})


def read_locomotion(path: Path):
    """The locomotion channels written into ``path`` (a :class:`~crowdmotion.locomotion.Locomotion`)."""
    try:
        table = pq.read_table(path)
    except Exception as exc:
        raise ValueError(f"{path} is not a readable Parquet file: {exc}") from exc
    meta = (table.schema.metadata or {}).get(_KEY)
    return locomotion_from_table(table, json.loads(meta) if meta else {})
