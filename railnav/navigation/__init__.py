"""Navigation: running a filter over a trip.

Owns the one chunk loop (`railnav.navigation.loop`) used by in-memory runs
(`navigator.navigate`), streamed runs (`streaming`) and multi-track bank runs (`bank`),
the filter start (`initialization`, with `InitialState`) and what a run produces (`result`,
`bank_result`).
"""
