"""The package's top-level names (railnav/__init__.py) are the owning modules' objects,
documented, and the CLI's functions are among them."""
from __future__ import annotations

import importlib

import pytest

import railnav


@pytest.mark.parametrize("name", railnav.__all__)
def test_top_level_name_is_the_owning_modules_object(name):
    owner = importlib.import_module(f"railnav.{railnav._EXPORTS[name]}")
    assert getattr(railnav, name) is getattr(owner, name)
    assert (getattr(railnav, name).__doc__ or "").strip()


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        railnav.nope  # noqa: B018
