"""The long-form table is built on numpy's buffers (no pandas import): its columns must
equal what pyarrow's own converters make of the same values."""

import subprocess
import sys

import numpy as np
import pyarrow as pa
import pytest

from crowdmotion.io.longform import _arrow, _tiled_strings
from crowdmotion.trajectories import Trajectories


@pytest.mark.parametrize("values", [
    np.array([True, False, True, True, False, False, True, True, False, True, True]),  # 11 bits: a partial byte
    np.arange(13, dtype=np.int64) - 6,
    np.linspace(-1.0, 2.0, 7),
    np.arange(20, dtype=np.float64).reshape(4, 5)[:, 1],  # strided: copied
    np.array([], dtype=np.float64),
    np.arange(5, dtype=">f8"),  # big-endian: converted, not misread
])
def test_arrow_columns_equal_pyarrow(values):
    native = values.astype(values.dtype.newbyteorder("="))  # pyarrow refuses byte-swapped arrays itself
    assert _arrow(values).equals(pa.array(native))


def test_tiled_strings_equal_pyarrow():
    per_agent = np.array(["north", "süd", "", "群"])
    got = _tiled_strings(per_agent, 3)
    assert got.equals(pa.array(np.tile(per_agent, 3).tolist(), pa.string()))
    assert _tiled_strings(per_agent, 0).equals(pa.array([], pa.string()))


def test_writing_a_table_imports_no_pandas():
    code = """
import sys, numpy as np
from crowdmotion.io.longform import to_table
from crowdmotion.trajectories import Trajectories
pos = np.random.default_rng(0).normal(size=(5, 3, 2))
tr = Trajectories(pos, dt=0.5, radius=np.array([0.3, 0.2, 0.25]), group=np.array(["a", "b", "a"], dtype=object))
assert to_table(tr).num_rows == 15
print("pandas" in sys.modules)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_metadata_is_strict_json_that_any_reader_parses():
    # an RVO run without personalities carries NaN per agent; JSON has no NaN
    import json

    from crowdmotion.io.longform import json_text, metadata_json

    traj = Trajectories(np.zeros((3, 2, 2)), 0.25, metadata={"personality": np.full((2, 5), np.nan).tolist(),
                                                               "best": np.float64(np.inf), "count": np.int64(3)})

    def refuse(name):
        raise ValueError(f"not JSON: {name}")

    meta = json.loads(metadata_json(traj), parse_constant=refuse)
    assert meta["personality"] == [[None] * 5] * 2 and meta["best"] is None and meta["count"] == 3
    assert json.loads(json_text({"a": (1.5, float("nan"))}), parse_constant=refuse) == {"a": [1.5, None]}
