"""Navigation: running a filter over a trip.

Owns the one chunk loop (`railnav.navigation.loop`) used by in-memory runs
(`navigator.navigate`) and streamed runs (`streaming`), the filter start (`initialization`,
with `InitialState`), what a run produces (`result`), and the multiple-hypothesis network
navigator (`network_navigator`, with what hypotheses on different tracks share: `bank`).
"""
