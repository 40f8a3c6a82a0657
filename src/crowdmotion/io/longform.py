"""Long-form table (frame, time, agent, group, x, y, z, radius, active, facing,
facing_pitch) <-> Trajectories."""

from __future__ import annotations

import json

import numpy as np
import pyarrow as pa

from crowdmotion.trajectories import Trajectories

COLUMNS = ("frame", "time", "agent", "group", "x", "y", "z", "radius", "active", "facing", "facing_pitch")


def to_table(traj: Trajectories) -> pa.Table:
    """One row per (frame, agent); 2D runs have no z or facing_pitch column (every column
    is numeric or text, so pandas, polars and DuckDB read the types right). ``facing`` is
    the way the agent faces, yaw in radians about the up axis from +x (``facing_pitch``:
    above the ground plane), see :mod:`crowdmotion.facing`."""
    t, n, d = traj.positions.shape
    frame = np.repeat(np.arange(t, dtype=np.int64), n)
    pos = traj.positions.reshape(t * n, d)
    columns = {
        "frame": frame,
        "time": frame * traj.dt,
        "agent": np.tile(traj.ids, t),
        "group": _tiled_strings(traj.group.astype(str), t),
        "x": pos[:, 0],
        "y": pos[:, 1],
    }
    if d == 3:
        columns["z"] = pos[:, 2]
    columns["radius"] = np.tile(traj.radius, t)
    columns["active"] = traj.active_mask.reshape(-1)
    columns["facing"] = traj.facing.reshape(-1)
    if d == 3:
        columns["facing_pitch"] = traj.facing_pitch.reshape(-1)
    return pa.Table.from_arrays([_arrow(v) for v in columns.values()], names=list(columns))


# Arrow arrays are built on numpy's buffers here: pa.array() and pa.table() look for
# pandas objects first and so import pandas, 0.4 s of every run's 1-3 s
def _arrow(values) -> pa.Array:
    """A 1-D numeric or boolean numpy array (or an Arrow array, passed through) as an
    Arrow array without a copy (booleans: packed to bits)."""
    if isinstance(values, pa.Array):
        return values
    values = np.ascontiguousarray(values)
    values = values.astype(values.dtype.newbyteorder("="), copy=False)  # Arrow's buffers are native-endian
    if values.dtype == bool:
        return pa.Array.from_buffers(pa.bool_(), len(values),
                                     [None, pa.py_buffer(np.packbits(values, bitorder="little"))])
    return pa.Array.from_buffers(pa.from_numpy_dtype(values.dtype), len(values), [None, pa.py_buffer(values)])


def _tiled_strings(per_agent: np.ndarray, times: int) -> pa.Array:
    """The agents' strings repeated ``times`` over (the table's frames), as an Arrow
    string array (64-bit offsets past 2 GiB of text)."""
    encoded = [s.encode() for s in per_agent]
    lengths = np.tile(np.array([len(e) for e in encoded], dtype=np.int64), times)
    offsets = np.zeros(len(lengths) + 1, dtype=np.int64)
    np.cumsum(lengths, out=offsets[1:])
    large = offsets[-1] >= 2**31
    kind = pa.large_string() if large else pa.string()
    offsets = offsets if large else offsets.astype(np.int32)
    text = pa.py_buffer(b"".join(encoded) * times)
    return pa.Array.from_buffers(kind, len(lengths), [None, pa.py_buffer(offsets), text])


def from_table(table: pa.Table, metadata: dict | None = None) -> Trajectories:
    """Inverse of :func:`to_table`; rows may come in any order."""
    missing = [c for c in ("frame", "agent", "x", "y") if c not in table.column_names]
    if missing:
        raise ValueError(f"trajectory table lacks columns {missing}; it has {table.column_names}")
    frame = table["frame"].to_numpy().astype(np.int64)
    agent = table["agent"].to_numpy().astype(np.int64)
    ids, col = np.unique(agent, return_inverse=True)
    frames, row = np.unique(frame, return_inverse=True)
    t, n = len(frames), len(ids)
    if len(frame) != t * n:
        raise ValueError(f"trajectory table has {len(frame)} rows, expected frames x agents = {t} x {n}")
    has_z = "z" in table.column_names and table["z"].null_count < len(table)
    d = 3 if has_z else 2
    pos = np.empty((t, n, d))
    pos[row, col, 0] = table["x"].to_numpy()
    pos[row, col, 1] = table["y"].to_numpy()
    if has_z:
        pos[row, col, 2] = table["z"].to_numpy()
    active = None
    if "active" in table.column_names:
        a = np.empty((t, n), dtype=bool)
        a[row, col] = table["active"].to_numpy(zero_copy_only=False)
        active = None if a.all() else a
    group = np.empty(n, dtype=object)
    group[col] = table["group"].to_pylist() if "group" in table.column_names else "agents"
    radius = np.zeros(n)
    if "radius" in table.column_names:
        radius[col] = table["radius"].to_numpy()
    if "time" in table.column_names and t > 1:
        times = np.empty(t)
        times[row] = table["time"].to_numpy()
        dt = float(np.median(np.diff(times)))
    else:
        dt = float((metadata or {}).get("dt", 1.0))
    facing = {}
    for name in ("facing", "facing_pitch"):  # older files carry none: derived again
        if name in table.column_names and table[name].null_count == 0:
            facing[name] = np.empty((t, n))
            facing[name][row, col] = table[name].to_numpy()
    return Trajectories(pos, dt, ids=ids, group=group, radius=radius, active=active, metadata=metadata or {},
                        **facing)


def metadata_json(traj: Trajectories) -> str:
    """Metadata as JSON, numpy values turned into plain lists/numbers, with what a reader
    needs to use the numbers: frame rate, dimension, units and axes."""
    return json.dumps({**traj.metadata, "dt": traj.dt, "fps": traj.fps, "dim": traj.dim,
                       "units": {"length": "m", "time": "s", "speed": "m/s"},
                       "axes": "x east, y north, z up; 2D runs lie on the ground plane"}, default=_plain)


def _plain(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)
