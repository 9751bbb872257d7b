"""GNSS position fixes from files: the I/O layer of loose coupling.

A fix is a receiver's own solution (position, optionally velocity or speed/course, a
quality flag, sometimes accuracies), as recorded by most railway loggers. This subpackage
reads fixes and writes them; it does no physics (the measurement model that uses them is
`railnav.filters.fix_rows`).

===============================  ==========================================================
module                           owns
===============================  ==========================================================
``table``                        the fix table every reader returns (`FIX_COLUMNS`,
                                 `FIX_QUALITIES`, `FixLog`)
``quality``                      σ from the fix class where the file has none: the
                                 documented table `DEFAULT_FIX_SIGMAS` and its overrides
``read``                         `read_fixes`: the format told from the content
                                 (`detect_fix_format`), read, σ completed
``csv_reader``                   CSV (pandas), including the Belgian train logs as shipped
``nmea_reader``                  NMEA 0183 GGA, RMC, VTG, GST, GSA (pynmea2)
``ubx_reader``                   u-blox UBX NAV-PVT (+ NAV-COV) (pyubx2)
``gpx_reader``                   GPX 1.0/1.1 (gpxpy)
``writers``                      CSV and NMEA output (pynmea2's sentence builder)
===============================  ==========================================================

Time: every table has ``gps_time_s`` (`gnss_obs.gpstime`, leap seconds applied to UTC
labels) and the file's own ``timestamp``.
"""
