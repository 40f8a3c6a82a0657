"""Test-session settings shared by every test module."""

#: the default run's longest tests (seconds on 2 cores), started first: `pytest -n 2`
#: hands tests out in collection order, and one of these begun last kept one worker busy
#: alone for a minute at the end
LONGEST_FIRST = (
    "test_the_record_matches_what_a_run_compiles[rvo]",  # 65-70
    "test_two_streams_in_a_corridor_form_lanes_and_pass",  # 25
    "test_the_avoidance_scene_redirects_most_particles_whatever_the_seed",  # 15
    "test_a_07_m_door_passes_a_dense_crowd_at_one_person_a_second_or_more",  # 15
    "test_workers_write_what_one_process_writes",  # 14
)


def pytest_collection_modifyitems(session, config, items):
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.name, len(rank)))  # stable: the rest keep their order
