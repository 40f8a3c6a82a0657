"""Parquet trajectory files: the long-form table with the metadata in the schema."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq

from crowdmotion.io.atomic import atomic_path
from crowdmotion.io.longform import from_table, metadata_json, to_table

_KEY = b"crowdmotion"


def write(traj, path: Path) -> None:
    table = to_table(traj)
    table = table.replace_schema_metadata({_KEY: metadata_json(traj).encode()})
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp, compression="zstd")


def read(path: Path):
    try:
        table = pq.read_table(path)
    except Exception as exc:  # pyarrow raises several types for corrupt files
        raise ValueError(f"{path} is not a readable Parquet file: {exc}") from exc
    meta = (table.schema.metadata or {}).get(_KEY)
    return from_table(table, json.loads(meta) if meta else {})
