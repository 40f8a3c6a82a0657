"""Long-form table (frame, time, agent, group, x, y, z, radius, active, facing,
facing_pitch, stage when agents follow routes, and the locomotion channels) <-> Trajectories."""

from __future__ import annotations

import json

import numpy as np
import pyarrow as pa

from crowdmotion.locomotion import STATES, Locomotion, LocomotionParams
from crowdmotion.trajectories import Trajectories

LOCOMOTION_COLUMNS = ("distance", "gait_phase", "gait_state", "turn_rate", "contact_left", "contact_right")
COLUMNS = ("frame", "time", "agent", "group", "x", "y", "z", "radius", "active", "facing", "facing_pitch",
           *LOCOMOTION_COLUMNS)


def to_table(traj: Trajectories, loco: Locomotion | None = None) -> pa.Table:
    """One row per (frame, agent); 2D runs have no z or facing_pitch column (every column
    is numeric or text, so pandas, polars and DuckDB read the types right). ``facing`` is
    the way the agent faces, yaw in radians about the up axis from +x (``facing_pitch``:
    above the ground plane), see :mod:`crowdmotion.facing`. ``stage`` (only when agents
    follow routes) is each agent's stage id, -1 off route or absent (the ids are listed
    in the metadata's ``stages``). Then the locomotion channels
    (``loco``, derived from ``traj`` with the default parameters when None; see
    :mod:`crowdmotion.locomotion`, single precision): ``distance`` (m), ``gait_phase`` (strides, [0, 1)),
    ``gait_state`` (text: idle, walk, run, turn, move), ``turn_rate`` (rad/s) and
    ``contact_left`` / ``contact_right``; phase and contacts are null for agents that
    are not walkers."""
    loco = traj.locomotion() if loco is None else loco
    t, n, d = traj.positions.shape
    frame = np.repeat(np.arange(t, dtype=np.int64), n)
    pos = traj.positions.reshape(t * n, d)
    columns = {
        "frame": frame,
        "time": np.round(frame * traj.dt, 9),  # 0.3, not 0.30000000000000004 (the exact step: metadata dt)
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
    if traj.stage is not None:  # runs with routes: each agent's stage id (-1 off route or absent)
        columns["stage"] = traj.stage.reshape(-1).astype(np.int16)
    gait = None if loco.walker.all() else np.tile(loco.walker, t)  # the rows that have a gait
    # float32 (single precision: 8 µm in 100 m, 1e-7 of a stride) keeps a run's file small
    columns["distance"] = loco.distance.reshape(-1).astype(np.float32)
    phase = np.mod(loco.gait_phase.reshape(-1).astype(np.float32), np.float32(1.0))  # 0.99999999 -> 0, not 1
    columns["gait_phase"] = _arrow(phase, gait)
    columns["gait_state"] = pa.DictionaryArray.from_arrays(  # text (Parquet dictionary-encodes it on disk)
        _arrow(loco.gait_state.reshape(-1)), _tiled_strings(np.array(STATES), 1)).cast(pa.string())
    columns["turn_rate"] = loco.turn_rate.reshape(-1).astype(np.float32)
    columns["contact_left"] = _arrow(loco.contact_left.reshape(-1), gait)
    columns["contact_right"] = _arrow(loco.contact_right.reshape(-1), gait)
    return pa.Table.from_arrays([_arrow(v) for v in columns.values()], names=list(columns))


# Arrow arrays are built on numpy's buffers here: pa.array() and pa.table() look for
# pandas objects first and so import pandas, 0.4 s of every run's 1-3 s
def _arrow(values, valid: np.ndarray | None = None) -> pa.Array:
    """A 1-D numeric or boolean numpy array (or an Arrow array, passed through) as an
    Arrow array without a copy (booleans: packed to bits); null where ``valid`` is False."""
    if isinstance(values, pa.Array):
        return values
    values = np.ascontiguousarray(values)
    values = values.astype(values.dtype.newbyteorder("="), copy=False)  # Arrow's buffers are native-endian
    nulls = None
    if valid is not None:
        nulls = pa.py_buffer(np.packbits(valid, bitorder="little"))
    if values.dtype == bool:
        return pa.Array.from_buffers(pa.bool_(), len(values),
                                     [nulls, pa.py_buffer(np.packbits(values, bitorder="little"))])
    return pa.Array.from_buffers(pa.from_numpy_dtype(values.dtype), len(values), [nulls, pa.py_buffer(values)])


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
    written = (metadata or {}).get("dt")  # the run's own step, exactly (the times carry rounding)
    if "time" in table.column_names and t > 1:
        times = np.empty(t)
        times[row] = table["time"].to_numpy()
        dt = float(np.median(np.diff(times)))
        if isinstance(written, (int, float)) and written > 0 and abs(dt - written) <= 1e-6 * written:
            dt = float(written)
    else:
        dt = float(1.0 if written is None else written)  # a bad one is refused by Trajectories, naming the file
    facing = {}
    for name in ("facing", "facing_pitch"):  # older files carry none: derived again
        if name in table.column_names and table[name].null_count == 0:
            facing[name] = np.empty((t, n))
            facing[name][row, col] = table[name].to_numpy()
    stage = None
    if "stage" in table.column_names:
        stage = np.full((t, n), -1, dtype=np.int16)
        stage[row, col] = table["stage"].fill_null(-1).to_numpy().astype(np.int16)
    return Trajectories(pos, dt, ids=ids, group=group, radius=radius, active=active, metadata=metadata or {},
                        stage=stage, **facing)


def locomotion_from_table(table: pa.Table, metadata: dict | None = None) -> Locomotion:
    """The locomotion channels of a table written by :func:`to_table` (rows in any order);
    a ValueError if it has none."""
    missing = [c for c in ("frame", "agent", "group", *LOCOMOTION_COLUMNS) if c not in table.column_names]
    if missing:
        raise ValueError(f"trajectory table lacks the locomotion columns {missing}")
    ids, col = np.unique(table["agent"].to_numpy().astype(np.int64), return_inverse=True)
    frames, row = np.unique(table["frame"].to_numpy().astype(np.int64), return_inverse=True)
    shape = (len(frames), len(ids))

    def grid(name, dtype, null):
        column = table[name]
        if pa.types.is_dictionary(column.type) or pa.types.is_string(column.type) \
                or pa.types.is_large_string(column.type):  # gait_state as text (CSV) or dictionary (Parquet)
            names, index = np.unique(np.array(column.cast(pa.string()).to_pylist(), dtype=object),
                                     return_inverse=True)
            unknown = sorted(set(names.tolist()) - set(STATES))
            if unknown:
                raise ValueError(f"gait_state holds {unknown!r}; states are {', '.join(STATES)}")
            values = np.array([STATES.index(s) for s in names], dtype=np.int8)[index]
        else:
            values = column.cast(pa.from_numpy_dtype(np.dtype(dtype))).fill_null(null).to_numpy(zero_copy_only=False)
        out = np.empty(shape, dtype)
        out[row, col] = values
        return out

    group = np.empty(len(ids), dtype=object)
    group[col] = table["group"].to_pylist()
    meta = (metadata or {}).get("locomotion") or {}
    kinds = meta.get("kinds") or {}
    kind = np.array([kinds.get(str(g), "walker") for g in group], dtype=object)
    params = LocomotionParams(**meta["params"]) if meta.get("params") else LocomotionParams()
    return Locomotion(grid("distance", float, np.nan), grid("gait_phase", float, np.nan),
                      grid("gait_state", np.int8, 0), grid("turn_rate", float, np.nan),
                      grid("contact_left", bool, False), grid("contact_right", bool, False), kind, params)


def locomotion_metadata(traj: Trajectories, loco: Locomotion) -> dict:
    """The ``locomotion`` entry of a file's metadata: state names, each group's body kind
    and the parameters the channels were derived with."""
    kinds = dict(zip(traj.group.astype(str).tolist(), loco.kind.tolist()))
    return {**loco.metadata(), "kinds": kinds}


def metadata_json(traj: Trajectories, loco: Locomotion | None = None) -> str:
    """Metadata as JSON, numpy values turned into plain lists/numbers, with what a reader
    needs to use the numbers: frame rate, dimension, units and axes (and, given ``loco``,
    the ``locomotion`` entry of :func:`locomotion_metadata`)."""
    extra = {} if loco is None else {"locomotion": locomotion_metadata(traj, loco)}
    return json_text({**traj.metadata, "dt": traj.dt, "fps": traj.fps, "dim": traj.dim,
                      "units": {"length": "m", "time": "s", "speed": "m/s", "turn_rate": "rad/s",
                                "gait_phase": "strides"},
                      "axes": "x east, y north, z up; 2D runs lie on the ground plane", **extra})


def json_text(obj, **options) -> str:
    """``obj`` as strict JSON, which every reader parses: numpy values as plain lists and
    numbers, NaN and infinities (not JSON) as null, anything else unknown as its text.
    ``options`` go to :func:`json.dumps` (``indent``, say)."""
    return json.dumps(_finite(obj), allow_nan=False, **options)


def _finite(obj):
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _finite(obj.tolist())
    if isinstance(obj, np.generic):
        return _finite(obj.item())
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    return str(obj)
