"""StateLayout: positions from blocks, and refusal of inconsistent layouts."""
from __future__ import annotations

import pytest

from ekf.errors import ModelError
from ekf.layout import StateLayout


def test_blocks_give_indices_slices_and_names():
    layout = StateLayout.from_blocks([("att", ("yaw", "pitch", "roll")), ("s", 1), ("v", 1),
                                      ("clock", 2)])
    assert layout.size == 7
    assert layout.slice("att") == slice(0, 3)
    assert layout.index("pitch") == 1
    assert layout.index("v") == 4
    assert layout.slice("clock") == slice(5, 7)
    assert layout.names == ("yaw", "pitch", "roll", "s", "v", "clock_0", "clock_1")
    bigger = layout.extended([("accel_bias", 3)])
    assert bigger.size == 10 and bigger.slice("accel_bias") == slice(7, 10)
    assert bigger.index("v") == 4


def test_bad_layouts_and_lookups_are_refused():
    layout = StateLayout.from_blocks([("att", 3), ("v", 1)])
    with pytest.raises(ModelError):
        layout.index("att")  # a block of 3 has no single index
    with pytest.raises(ModelError, match="no block"):
        layout.slice("speed")
    with pytest.raises(ModelError):
        StateLayout.from_blocks([("a", 1), ("a", 1)])
    with pytest.raises(ModelError):
        StateLayout.from_blocks([("a", 0)])
