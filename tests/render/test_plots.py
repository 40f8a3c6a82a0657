"""Pictures a user can read (issue 15.8): group colours that match their names, legends
beside the scene, start/end markers explained, big crowds sampled, density scale clipped."""

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion.render import animation, plots
from crowdmotion.trajectories import Trajectories


@pytest.fixture
def captured(monkeypatch):
    figs = []

    def keep(fig, path):
        figs.append(fig)
        return path

    monkeypatch.setattr(plots, "_save", keep)
    monkeypatch.setattr(animation, "_save", keep)
    return figs


def test_groups_named_after_colours_get_those_colours():
    c = plots.group_colours(["red", "blue", "walkers", "tab:blue"])
    assert c["red"] == (1.0, 0.0, 0.0, 1.0) and c["blue"] == (0.0, 0.0, 1.0, 1.0)
    assert len(set(c.values())) == 4, "a named colour is not handed to another group"


def _crowd(n, frames=5):
    rng = np.random.default_rng(0)
    pos = np.cumsum(rng.normal(size=(frames, n, 2)), axis=0) + 20
    return Trajectories(pos, 0.5, group=np.array(["a"] * (n // 2) + ["b"] * (n - n // 2), dtype=object))


def test_paths_legend_sits_beside_the_scene_and_explains_the_markers(captured, tmp_path):
    plots.plot_paths(_crowd(10), cm.Scene(bounds=([0, 0], [40, 40])), tmp_path / "p.png")
    ax = captured[0].axes[0]
    legend = ax.get_legend()
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels[:2] == ["a", "b"] and "start" in labels and any("end" in t for t in labels)
    assert legend.get_bbox_to_anchor().x0 >= ax.get_window_extent().x1 - 1, "outside the axes"
    assert ax.get_xlabel() == "x (m)"


def test_a_big_crowd_draws_a_sample_of_its_paths_and_says_so(captured, tmp_path):
    plots.plot_paths(_crowd(2000), cm.Scene(bounds=([0, 0], [40, 40])), tmp_path / "p.png")
    ax = captured[0].axes[0]
    assert f"({plots.MAX_PATHS} of 2000 paths drawn)" in ax.get_title()
    assert len(ax.lines) <= 2 * plots.MAX_PATHS


def test_one_hot_cell_does_not_flatten_the_density_scale(captured, tmp_path):
    pos = np.full((50, 40, 2), 5.0)  # agent 0 stands at (5, 5) all along
    pos[:, 1:, 0] = np.linspace(0.5, 39.5, 50)[:, None]  # 39 walkers cross the scene in rows
    pos[:, 1:, 1] = np.linspace(0.5, 9.5, 39)[None, :]
    traj = Trajectories(pos, 0.5, metadata={"scene": cm.Scene(bounds=([0, 0], [40, 10])).to_dict()})
    animation.plot_density(traj, tmp_path / "d.png", cell=1.0)
    ax = captured[0].axes[0]
    image = ax.get_images()[0]
    assert image.norm.vmax < 0.5, "the standing agent's cell (1 /m²) is off the scale"
    assert "clipped" in ax.get_title(loc="left")


def test_the_player_uses_the_same_group_colours_as_the_pictures():
    from crowdmotion.render.player import player_data

    traj = Trajectories(np.zeros((2, 2, 2)) + [[1, 1], [2, 2]], 1.0, group=np.array(["red", "crowd"], dtype=object))
    data = player_data(traj)
    assert data["groups"] == [{"name": "red", "colour": "#ff0000"}, {"name": "crowd", "colour": "#1f77b4"}]


def test_formation_gif_moves_obstacles_and_draws_torn_edges_where_they_are(tmp_path):
    from PIL import Image

    scene = cm.Scene([[0.0, 0.0], [10.0, 10.0]],
                     [cm.Circle([2.0, 5.0], 0.6, path=([0.0, 10.0], [[2.0, 5.0], [8.0, 5.0]]))])
    mesh = {"name": "blue", "vertices": np.array([[2.0, 2.0], [6.0, 2.0], [4.0, 4.0]]),
            "edges": np.array([[0, 1], [1, 2], [2, 0]]), "torn": np.array([False, True, False]),
            "agents": np.array([[2.0, 2.0], [6.0, 2.0], [4.0, 4.0]]), "radius": 0.3,
            "dislocated": np.zeros(3, bool)}
    path = plots.animate_formation_snapshots(scene, [{"time": 0.0, "groups": [mesh]}, {"time": 10.0, "groups": [mesh]}],
                                             tmp_path / "f.gif", title="t")
    gif = Image.open(path)

    def colour(frame, x, y):  # the figure's fixed margins: 0.75 in left, 0.35 in top, 8 in of data, 72 dpi
        gif.seek(frame)
        rgb = np.asarray(gif.convert("RGB")).astype(int)
        col, row = round((0.75 + 0.8 * x) * 72), round((0.35 + 0.8 * (10 - y)) * 72)
        return rgb[row - 1:row + 2, col - 1:col + 2].reshape(-1, 3)

    for frame, here, gone in ((0, 2.0, 8.0), (1, 8.0, 2.0)):
        assert colour(frame, here, 5.4).max() < 200, "the obstacle is drawn where it is at that time"
        assert colour(frame, gone, 5.4).min() > 240, "and not where it was or will be (above its dashed path)"
        torn = colour(frame, 5.0, 3.0)  # the middle of the torn edge (1, 2): red, dashed
        intact = colour(frame, 3.0, 2.0)  # the middle of the intact edge (0, 1): blue
        assert (torn[:, 0] - torn[:, 2]).max() > 60 or (torn.min(axis=1) > 240).all()  # a dash or a gap
        assert (intact[:, 2] - intact[:, 0]).max() > 60


def test_an_obstacle_that_stood_for_part_of_the_run_is_a_dashed_outline_in_paths_and_shown_only_then_in_frames(
        captured, tmp_path):
    scene = cm.Scene([[0.0, 0.0], [10.0, 5.0]], [cm.Box([8, 0], [9, 1]), cm.Box([4, 0], [4.5, 2]).during(0.0, 3.0)])
    t = np.arange(60) * 0.1
    pos = np.stack([1 + t[:, None] + 0 * np.arange(2), 3 + np.arange(2) + 0 * t[:, None]], axis=-1)
    traj = Trajectories(pos, 0.1, radius=[0.2, 0.2], metadata={"scene": scene.to_dict()})
    plots.plot_paths(traj, scene, tmp_path / "p.png")
    wall, door = [p for p in captured[-1].axes[0].patches if isinstance(p, plots.patches.Rectangle)][:2]
    assert wall.get_facecolor()[3] > 0 and wall.get_linestyle() in ("-", "solid")
    assert door.get_facecolor()[3] == 0 and door.get_linestyle() in ("--", "dashed"), "the door stood for the first 3 s only"
    import matplotlib.pyplot as plt

    for when, shown in ((1.0, True), (4.0, False)):
        fig, ax = plt.subplots()
        drawn = plots._draw_obstacles_2d(ax, scene, when, at_t=True)
        assert [ob.present for ob, _ in drawn if ob.is_timed] == ([(0.0, 3.0)] if shown else [])
        plt.close(fig)
    fig, ax = plt.subplots()  # blitted frames: the patch made once, shown while it stands
    movers = plots._draw_obstacles_2d(ax, scene, moving=True, animated=True, at_t=True)
    assert [p.get_visible() for p in plots.move_obstacles(ax, movers, 1.0)] == [True]
    assert [p.get_visible() for p in plots.move_obstacles(ax, movers, 4.0)] == [False]
    plt.close(fig)


def test_routes_without_a_queue_get_the_exits_alone_not_an_empty_panel(captured, tmp_path):
    from types import SimpleNamespace

    class Queue:
        stage = SimpleNamespace(name="gate")

        def report(self):
            return {"length_per_s": [0, 3, 5, 2, 0]}

    exits = {"north": [3.0, 4.5, 6.0], "south": [5.0]}
    plots.plot_journeys(SimpleNamespace(queues=[], exits=exits), tmp_path / "j.png")
    plots.plot_journeys(SimpleNamespace(queues=[Queue()], exits=exits), tmp_path / "j.png")
    alone, both = captured
    assert [ax.get_title() for ax in alone.axes] == ["exits"]
    assert [ax.get_title() for ax in both.axes] == ["queues", "exits"]
    assert all(ax.has_data() for ax in alone.axes + both.axes)


def test_a_moving_obstacle_in_the_paths_picture_is_explained_in_its_legend(captured, tmp_path):
    # the walkers' paths cross the spot it stood on at the start: the legend says so
    scene = cm.Scene(bounds=([0, 0], [20, 10]),
                     obstacles=[cm.Circle([10, 2], 1.0, path=([0, 10], [[0, 0], [0, 6]]))])
    pos = np.linspace([[1.0, 2.0]], [[19.0, 2.0]], 11)
    plots.plot_paths(Trajectories(pos, 1.0), scene, tmp_path / "p.png")
    labels = [t.get_text() for t in captured[0].axes[0].get_legend().get_texts()]
    assert "moving obstacle, at the start" in labels and "its path" in labels
    still = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Circle([10, 8], 1.0)])
    plots.plot_paths(Trajectories(pos, 1.0), still, tmp_path / "q.png")
    still_labels = [t.get_text() for t in captured[1].axes[0].get_legend().get_texts()]
    assert "its path" not in still_labels and "obstacle" in still_labels  # grey rocks are not end dots
    assert "obstacle" not in labels


def test_a_long_corridor_is_drawn_high_enough_to_see_and_says_its_y_is_stretched(tmp_path):
    # a 120 x 4 m corridor to scale was a strip 125 px high, its title over the y label;
    # a verify case's title listed every run's measures (a picture 10,810 px wide)
    from PIL import Image

    tr = Trajectories(np.stack([np.linspace([1, 2], [100, 2], 20)] * 3, axis=1), 0.5)
    title = "; ".join(f"run {k}: 1.00 m/s" for k in range(40))
    out = plots.plot_paths(tr, cm.Scene(bounds=([0, 0], [120, 4])), tmp_path / "p.png", title=title)
    width, height = Image.open(out).size
    assert height >= 250 and width <= 1400, (width, height)
    tall = plots.plot_paths(tr, cm.Scene(bounds=([0, 0], [120, 1200])), tmp_path / "t.png")
    assert Image.open(tall).size[1] <= 1400


def test_formation_pictures_draw_a_group_that_enters_after_the_first_snapshot(tmp_path):
    scene = cm.Scene([[0.0, 0.0], [10.0, 10.0]])
    mesh = {"name": "soldiers", "vertices": np.array([[2.0, 2.0], [6.0, 2.0], [4.0, 4.0]]),
            "edges": np.array([[0, 1], [1, 2], [2, 0]]), "torn": np.zeros(3, bool),
            "agents": np.array([[2.0, 2.0], [6.0, 2.0], [4.0, 4.0]]), "radius": 0.3, "dislocated": np.zeros(3, bool)}
    snapshots = [{"time": 0.0, "groups": []}, {"time": 5.0, "groups": [mesh]}]  # not in yet at t = 0
    assert plots.animate_formation_snapshots(scene, snapshots, tmp_path / "f.gif").exists()
    assert list(plots._snapshot_colours(snapshots)) == ["soldiers"]


def test_a_floor_of_many_rooms_gives_every_group_its_own_colour():
    # twelve groups drew the eleventh and twelfth in the first two's colours (tab10 cycled)
    from matplotlib import colormaps

    names = [f"room {k}" for k in range(40)]
    colours = plots.group_colours(names)
    assert len(set(colours.values())) == 40
    assert [colours[n] for n in names[:10]] == [colormaps["tab10"](i) for i in range(10)]  # as before


def test_a_few_walkers_in_a_large_world_are_drawn_zoomed_on_their_paths_and_a_crowd_over_it_is_not():
    from crowdmotion.render.plots import ZOOM_PAD_M, _view_2d

    scene = cm.Scene(bounds=([-100, -100], [100, 100]))
    walk = np.stack([np.linspace(-10, 15, 50), np.zeros(50)], axis=1)  # SteerSuite's squeeze: 25 m of 200
    traj = cm.Trajectories(np.stack([walk, walk[::-1] + [0, 1]], axis=1), 0.25)
    lo, hi = _view_2d(traj, scene, np.arange(2), None, None)
    assert lo[0] == pytest.approx(-10 - 0.15 * 25) and hi[0] == pytest.approx(15 + 0.15 * 25)
    assert lo[1] == pytest.approx(-0.15 * 25) and hi[1] == pytest.approx(1 + 0.15 * 25)
    wide = cm.Trajectories(np.stack([walk * 6, walk[::-1] + [0, 1]], axis=1), 0.25)  # 150 m: the whole world
    assert [v.tolist() for v in _view_2d(wide, scene, np.arange(2), None, None)] == [[-100, -100], [100, 100]]
    lone = cm.Trajectories(np.zeros((3, 1, 2)), 0.25)  # one standing still: a few metres round it
    lo, hi = _view_2d(lone, scene, np.arange(1), None, None)
    assert lo.tolist() == [-ZOOM_PAD_M, -ZOOM_PAD_M] and hi.tolist() == [ZOOM_PAD_M, ZOOM_PAD_M]
