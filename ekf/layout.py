"""The state layout: the one object that maps state names to indices and slices.

STYLE.md 2.2: "the state vector has one layout object ... Never write ``x[6]``". A
:class:`StateLayout` is built once from ``(name, size)`` blocks, in order, and every part
of a filter (model, driver, result writer) asks it for positions::

    layout = StateLayout.from_blocks([("att", 3), ("s", 1), ("v", 1), ("clock", 2)])
    layout.slice("att")   # slice(0, 3)
    layout.index("v")     # 4
    layout.names          # ('att_0', 'att_1', 'att_2', 's', 'v', 'clock_0', 'clock_1')

A block of size 1 is a scalar state and is named after the block; the components of a
larger block are named ``<block>_<i>`` unless component names are given
(``("att", ("yaw", "pitch", "roll"))``), in which case each component is also
addressable on its own.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

from ekf.errors import ModelError

__all__ = ["StateLayout"]

BlockSpec = tuple[str, "int | Sequence[str]"]


@dataclass(frozen=True)
class StateLayout:
    """Names and positions of the components of a state (or measurement) vector.

    Parameters
    ----------
    blocks : tuple of (str, int, int)
        ``(block name, start, stop)`` in order, contiguous from 0. Use
        :meth:`from_blocks` rather than this constructor.
    names : tuple of str
        One name per component, ``len(names) == size``.

    Raises
    ------
    ModelError
        Blocks that are not contiguous, empty, or names that repeat.
    """

    blocks: tuple[tuple[str, int, int], ...]
    names: tuple[str, ...]
    _where: dict[str, tuple[int, int]] = field(init=False, repr=False, compare=False)
    #: The index of each scalar block or component (`index`'s answer, looked up once).
    _scalar: dict[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        where: dict[str, tuple[int, int]] = {}
        stop_prev = 0
        for name, start, stop in self.blocks:
            if start != stop_prev or stop <= start:
                raise ModelError(f"layout block {name!r}: [{start}, {stop}) must be a "
                                 f"non-empty block starting at {stop_prev}")
            where[name] = (start, stop)
            stop_prev = stop
        if len(self.names) != stop_prev:
            raise ModelError(f"layout has {stop_prev} components but {len(self.names)} names")
        for i, name in enumerate(self.names):
            if name in where and where[name] != (i, i + 1):
                raise ModelError(f"layout name {name!r} is used twice")
            where.setdefault(name, (i, i + 1))
        if len(set(self.names)) != len(self.names):
            raise ModelError(f"layout component names repeat: {self.names}")
        object.__setattr__(self, "_where", where)
        object.__setattr__(self, "_scalar", {name: start for name, (start, stop)
                                             in where.items() if stop - start == 1})

    @classmethod
    def from_blocks(cls, blocks: Sequence[BlockSpec]) -> "StateLayout":
        """Build a layout from ``(name, size)`` or ``(name, component names)`` blocks.

        Parameters
        ----------
        blocks : sequence of (str, int) or (str, sequence of str)
            Blocks in state order. An int gives the block size; a sequence of
            strings gives the names of its components (its length is the size).

        Returns
        -------
        StateLayout
        """
        spans: list[tuple[str, int, int]] = []
        names: list[str] = []
        start = 0
        for name, spec in blocks:
            if isinstance(spec, int):
                size = spec
                comp = [name] if size == 1 else [f"{name}_{i}" for i in range(size)]
            else:
                comp = [str(c) for c in spec]
                size = len(comp)
            spans.append((str(name), start, start + size))
            names.extend(comp)
            start += size
        return cls(blocks=tuple(spans), names=tuple(names))

    @property
    def size(self) -> int:
        """Number of components of the vector."""
        return len(self.names)

    def slice(self, name: str) -> slice:
        """The slice of a block (or of a single named component).

        Raises
        ------
        ModelError
            Unknown name.
        """
        start, stop = self._lookup(name)
        return slice(start, stop)

    def index(self, name: str) -> int:
        """The index of a scalar block or of a named component.

        Raises
        ------
        ModelError
            Unknown name, or a block of more than one component.
        """
        found = self._scalar.get(name)
        if found is not None:
            return found
        start, stop = self._lookup(name)
        if stop - start != 1:
            raise ModelError(f"layout block {name!r} has {stop - start} components; "
                             "use slice()")
        return start

    def block_names(self) -> tuple[str, ...]:
        """The block names, in state order."""
        return tuple(b[0] for b in self.blocks)

    def extended(self, blocks: Sequence[BlockSpec]) -> "StateLayout":
        """A new layout with ``blocks`` appended (e.g. optional sensor biases)."""
        own: list[BlockSpec] = []
        for name, start, stop in self.blocks:
            comp = self.names[start:stop]
            own.append((name, comp if comp != (name,) else 1))
        return StateLayout.from_blocks([*own, *blocks])

    def _lookup(self, name: str) -> tuple[int, int]:
        try:
            return self._where[name]
        except KeyError:
            raise ModelError(f"layout has no block or component {name!r}; "
                             f"blocks are {self.block_names()}") from None
