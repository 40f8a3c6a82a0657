"""Memory sizes as a user writes them, and the memory available now."""

import pytest

from crowdmotion.memory import available_memory, human_bytes, parse_size


@pytest.mark.parametrize("text,size", [("8G", 8 << 30), ("512MiB", 512 << 20), ("2.5GB", 2_500_000_000),
                                       ("1024", 1024), (" 1 k ", 1024), ("1e3", 1000)])
def test_a_memory_size_reads_as_written(text, size):
    assert parse_size(text) == size


@pytest.mark.parametrize("text", ["lots", "", "-1G", "0", "1e400", "8 parsecs"])
def test_a_memory_size_that_is_not_one_is_refused_naming_it(text):
    with pytest.raises(ValueError, match="memory size"):
        parse_size(text)


def test_sizes_print_in_binary_units_and_the_machine_says_what_is_available():
    assert human_bytes(1536) == "1.5 KiB" and human_bytes(3 << 30) == "3.0 GiB" and human_bytes(10) == "10 B"
    free = available_memory()
    assert free is None or free > 0
