"""The on-disk cache of loaded network folders (`railnav.jobs.network_cache`): a hit is the
network the folder reads as (every netelement's geometry, the connections), without
reading it; an edited folder, an unreadable pickle or an unwritable cache directory read
the folder again and give the same result as without a cache."""
from __future__ import annotations

import numpy as np
import pytest

from railnav.jobs.network import load_network
from railnav.jobs.network_cache import cached_network_folder
from railnav.simulation.scenarios import TRACKS_DIR
from trackmodel.network_io import read_network, write_network

SWITCH = TRACKS_DIR.parent / "networks" / "brussels_switch.geojson"


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """The shipped switch (two netelements and their connection) as a network folder."""
    path = tmp_path_factory.mktemp("net") / "switch"
    write_network(load_network(SWITCH), path)
    return path


def _same(a, b) -> None:
    assert sorted(a.elements) == sorted(b.elements)
    assert a.connections == b.connections
    for name, track in a.elements.items():
        s = np.linspace(0.0, track.length_m, 7)
        for x, y in zip(track.geodetic(s), b.elements[name].geodetic(s)):
            np.testing.assert_array_equal(x, y)


class _Counted:
    def __init__(self):
        self.calls = 0

    def __call__(self, path):
        self.calls += 1
        return read_network(path)


def test_a_hit_is_the_folder_without_reading_it(folder, tmp_path):
    load = _Counted()
    first = cached_network_folder(folder, load, cache_dir=tmp_path)
    second = cached_network_folder(folder, load, cache_dir=tmp_path)
    assert load.calls == 1 and len(list(tmp_path.glob("*.pickle"))) == 1
    _same(read_network(folder), first)
    _same(first, second)


def test_an_edited_folder_is_read_again(folder, tmp_path):
    import shutil
    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    load = _Counted()
    cached_network_folder(copy, load, cache_dir=tmp_path / "cache")
    element = sorted((copy / "elements").iterdir())[0]
    element.write_text(element.read_text() + "\n")      # same geometry, other bytes
    again = cached_network_folder(copy, load, cache_dir=tmp_path / "cache")
    assert load.calls == 2 and len(list((tmp_path / "cache").glob("*.pickle"))) == 2
    _same(read_network(copy), again)


def test_an_unreadable_pickle_reads_the_folder_and_is_replaced(folder, tmp_path):
    load = _Counted()
    cached_network_folder(folder, load, cache_dir=tmp_path)
    (target,) = tmp_path.glob("*.pickle")
    target.write_bytes(b"not a pickle")
    network = cached_network_folder(folder, load, cache_dir=tmp_path)
    assert load.calls == 2
    _same(read_network(folder), network)
    _same(network, cached_network_folder(folder, load, cache_dir=tmp_path))
    assert load.calls == 2


def test_an_unwritable_cache_directory_still_reads(folder, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("a file where the cache directory would be")
    load = _Counted()
    network = cached_network_folder(folder, load, cache_dir=blocker / "networks")
    assert load.calls == 1
    _same(read_network(folder), network)


def test_an_object_that_cannot_be_pickled_leaves_nothing(tmp_path):
    """The loaded object goes back to the caller even when it cannot be pickled, and no
    temporary file is left in the cache directory."""
    def load(path):
        return lambda: path                          # a lambda cannot be pickled

    (tmp_path / "folder").mkdir()
    network = cached_network_folder(tmp_path / "folder", load, cache_dir=tmp_path / "cache")
    assert callable(network)
    assert list((tmp_path / "cache").iterdir()) == []
