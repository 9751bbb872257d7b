"""Filters: what a filter object is and the filters railnav runs.

Owns the filter protocol and the registry of filter kinds (`railnav.filters.protocol`), the
three filters (`constrained`, `unconstrained`, `gnss_only`) with their process models
(`*_model`, `ins_clock_model`), the GNSS rows they build (`gnss_rows`, `geodetic_rows`,
`robust_rows`, per-epoch preparation in `gnss_epochs`), the track geometry they use
(`track_grid`, `geometry_noise`) and the satellite fault screen (`fault_detection`,
`fault_channels`). Nothing here runs a trip: that is `railnav.navigation`.
"""
