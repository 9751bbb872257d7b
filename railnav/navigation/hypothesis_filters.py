"""The filters of the network navigator's hypotheses: one per hypothesis, on its track.

`FilterFactory` makes the filter object of the run's kind on a hypothesis's track (pieces,
`railnav.navigation.net_tracks`) for `railnav.navigation.network_navigator.navigate_network`:
a start's, a child's that goes on from its parent's memory (`FilterFactory.child`: the
along-track force's, ``inherit_memory``, and the fault screen's channels,
`parent_screen_copy`), and one shared template per track for the outputs
(`railnav.navigation.network_result`).
"""
from __future__ import annotations

from railnav.config import NavigatorConfig
from railnav.filters.bank_noise_scale import BankNoiseScale
from railnav.filters.fault_detection import RowScreen
from railnav.filters.protocol import make_filter
from railnav.navigation.net_tracks import OrientedTracks

__all__ = ["FilterFactory", "parent_screen_copy"]


class FilterFactory:
    """Filter objects of the run's kind on the tracks of hypotheses (pieces,
    `railnav.navigation.net_tracks`).

    Each hypothesis gets its own (its fault screen keeps per-channel memory); a child
    inherits its parent's channels (`child`). The GNSS rows' noise scale is the run's
    one, `noise_scale` (`railnav.filters.bank_noise_scale.BankNoiseScale`: each filter has a
    member of it). `template` is one shared object per track for outputs (its
    ``estimates``), never stepped.
    """

    def __init__(self, tracks: OrientedTracks, config: NavigatorConfig, trip) -> None:
        self.tracks, self.config, self.trip = tracks, config, trip
        self._templates: dict[tuple, object] = {}
        #: The noise scale of every hypothesis's GNSS rows (the cycles of
        #: `railnav.navigation.network_navigator` feed it).
        self.noise_scale = BankNoiseScale(config.noise_scale)

    def __call__(self, pieces):
        trip = self.trip
        filt = make_filter(self.tracks.placed(pieces), self.config, trip.gnss,
                           fixes=trip.fixes,
                           schedule=trip.schedule if trip.fixes is not None else None)
        if hasattr(filt, "use_noise_scale"):
            filt.use_noise_scale(self.noise_scale.member())
        return filt

    def child(self, parent, pieces):
        """A filter for `parent`'s child (or rebased self) on `pieces` (with the parent
        filter's memory where its kind keeps one: ``inherit_memory``)."""
        filt = self(pieces)
        if type(filt) is type(parent.filt) and hasattr(filt, "inherit_memory"):
            filt.inherit_memory(parent.filt)
        screen = getattr(parent.filt, "screen", None)
        if isinstance(screen, RowScreen) and isinstance(getattr(filt, "screen", None),
                                                        RowScreen):
            filt.screen = parent_screen_copy(screen, observer=filt.screen.observer)
        return filt

    def template(self, pieces):
        """The shared output filter object of `pieces`' track."""
        key = tuple(pieces)
        if key not in self._templates:
            self._templates[key] = self(key)
        return self._templates[key]


def parent_screen_copy(screen: RowScreen, observer=None) -> RowScreen:
    """A fault screen with `screen`'s channel states and no records (`observer`: its
    `RowScreen.observer`: the child's own)."""
    import copy
    out = RowScreen(screen.config, screen.clock_index, observer=observer)
    out._channels = copy.deepcopy(screen._channels)
    out._n_states = screen._n_states
    return out
