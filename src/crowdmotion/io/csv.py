"""CSV trajectory files: the long-form table; metadata goes to a ``.meta.json`` sidecar."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.csv as pacsv

from crowdmotion.io.atomic import atomic_path
from crowdmotion.io.longform import from_table, metadata_json, to_table


def sidecar(path: Path) -> Path:
    return path.with_name(path.name + ".meta.json")


def write(traj, path: Path) -> None:
    table = to_table(traj)
    with atomic_path(path) as tmp:
        pacsv.write_csv(table, tmp)
    with atomic_path(sidecar(path)) as tmp:
        tmp.write_text(metadata_json(traj))


def read(path: Path):
    try:
        table = pacsv.read_csv(path)
    except Exception as exc:
        raise ValueError(f"{path} is not a readable trajectory CSV: {exc}") from exc
    meta = {}
    if sidecar(path).is_file():
        meta = json.loads(sidecar(path).read_text())
    return from_table(table, meta)
