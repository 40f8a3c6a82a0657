"""How a run's pictures are shared out between the picture process's parts."""

import pytest

from crowdmotion.outputs import OutputFolderError, folder_inside, picture_parts

FORMATION_PLOTS = ["paths", "values", "snapshots", "player"]
SPLIT = {"snapshots": ("snapshots-figure", "snapshots-animation")}


def test_every_picture_is_in_exactly_one_part_in_its_given_order():
    for parts in (1, 2, 3, 8):
        got = picture_parts(FORMATION_PLOTS, parts, SPLIT)
        flat = [n for part in got for n in part]
        assert sorted(flat) == sorted(["paths", "values", "snapshots-figure", "snapshots-animation", "player"])
        for part in got:
            order = ["paths", "values", "snapshots-figure", "snapshots-animation", "player"]
            assert part == sorted(part, key=order.index)
        assert len(got) == min(parts, 5)


def test_the_formation_gif_is_drawn_apart_from_the_rest_on_two_cores():
    assert picture_parts(FORMATION_PLOTS, 2, SPLIT) == [["snapshots-animation"],
                                                         ["paths", "values", "snapshots-figure", "player"]]


def test_one_part_keeps_the_names_as_given_without_a_split():
    assert picture_parts(FORMATION_PLOTS, 1) == [FORMATION_PLOTS]
    assert picture_parts(["paths", "player"], 2) == [["paths"], ["player"]]


@pytest.mark.parametrize("name", ["..", "../x", "a/../../x", "/tmp/elsewhere", "", ".", "a\x00b"])
def test_a_name_that_leads_out_of_the_output_root_is_refused_even_past_the_schema(tmp_path, name):
    with pytest.raises(OutputFolderError, match="outside"):
        folder_inside(tmp_path / "out", name)


def test_a_plain_name_gives_a_folder_inside_the_output_root(tmp_path):
    assert folder_inside(tmp_path / "out", "street") == tmp_path / "out" / "street"
    assert folder_inside(tmp_path / "out", "a/b") == tmp_path / "out" / "a" / "b"  # nested, still inside
