"""The HTML player in a real headless Chromium: it loads, plays, the canvas changes, and
the page reports no errors. Chromium is Debian's package; .ci/run installs it and sets
CROWDMOTION_REQUIRE_CHROMIUM so that CI fails rather than skips without it."""

import json
import os
import re
import shutil
import subprocess

import numpy as np
import pytest

from crowdmotion import Trajectories
from crowdmotion.render.player import player_data, write_player
from crowdmotion.scene import Box, Circle, Scene

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def _run(dim=2):
    t = np.arange(60) * 0.1
    k = np.arange(6)
    pos = np.stack([1 + t[:, None] + 0 * k, 1 + 0.6 * k + 0 * t[:, None]], axis=-1)
    if dim == 3:
        pos = np.concatenate([pos, 1 + 0.1 * t[:, None, None] + 0 * pos[..., :1]], axis=-1)
    scene = Scene(((0, 0), (10, 5)), [Circle((5, 4.5), 0.4, path=([0.0, 6.0], [(5, 4.5), (5, 0.5)])),
                                     Box((8, 0), (9, 1))]) if dim == 2 else None
    meta = {"scene": scene.to_dict(), "scenario": "<test>"} if scene else {"scenario": "3d"}
    return Trajectories(pos, 0.1, group=np.array(["a", "a", "a", "b", "b", "b"], object), radius=[0.2] * 6,
                        metadata=meta)


def _selftest(page, tmp_path):
    if CHROMIUM is None:
        if os.environ.get("CROWDMOTION_REQUIRE_CHROMIUM"):
            pytest.fail("chromium is not installed but CROWDMOTION_REQUIRE_CHROMIUM is set")
        pytest.skip("chromium not installed (Debian package 'chromium')")
    out = subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=3000",
                          "--dump-dom", f"file://{page}#selftest"], capture_output=True, text=True, timeout=120)
    m = re.search(r'<pre id="selftest">([^<]*)</pre>', out.stdout)
    assert m and m.group(1), f"the page did not run its self-test:\n{out.stdout[-2000:]}\n{out.stderr[-2000:]}"
    return json.loads(m.group(1)), out.stderr


@pytest.mark.parametrize("dim", [2, 3])
def test_player_plays_in_headless_chromium_without_errors(tmp_path, dim):
    page = write_player(_run(dim), tmp_path / "view.html")
    html = page.read_text()
    assert "http://" not in html and "https://" not in html  # nothing fetched: works offline
    result, stderr = _selftest(page, tmp_path)
    assert result["errors"] == []
    assert result["changed_pixels"] > 100 and result["frames"] == 60
    assert result["gait_pixels"] > 100  # the gait rings and feet are drawn
    assert "Uncaught" not in stderr


def test_player_data_round_trips_positions_and_escapes_names():
    import base64

    tr = _run()
    data = player_data(tr)
    pos = np.frombuffer(base64.b64decode(data["positions"]), np.float32).reshape(60, 6, 2)
    np.testing.assert_allclose(pos, tr.positions, rtol=1e-6)
    assert [g["name"] for g in data["groups"]] == ["a", "b"]


def test_player_data_carries_each_agents_gait_state_and_feet():
    import base64

    from crowdmotion.locomotion import locomotion

    tr = _run()
    data = player_data(tr)
    gait = np.frombuffer(base64.b64decode(data["gait"]), np.uint8).reshape(60, 6)
    loco = locomotion(tr)
    np.testing.assert_array_equal(gait & 7, loco.gait_state)
    np.testing.assert_array_equal((gait >> 3) & 1, loco.contact_left)
    np.testing.assert_array_equal((gait >> 4) & 1, loco.contact_right)
    assert [s["name"] for s in data["states"]] == ["idle", "walk", "run", "turn", "move"]


def test_player_draws_a_door_only_while_it_stands(tmp_path):
    # a door removed at 3 s (a live Simulator's remove_obstacle), a wall put in at 3 s
    tr = _run()
    scene = Scene(((0, 0), (10, 5)), [Box((8, 0), (9, 1)), Box((4, 0), (4.5, 2)).during(0.0, 3.0),
                                      Box((6, 3), (7, 5)).during(3.0)])
    tr.metadata["scene"] = scene.to_dict()
    result, _ = _selftest(write_player(tr, tmp_path / "door.html"), tmp_path)
    assert result["errors"] == []
    assert result["standing"] == [[True, True], [True, False], [False, True]], "first frame, last frame"
