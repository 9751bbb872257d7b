"""gnss_obs — GNSS observations and their models.

Owns: GPS time and GNSS constants (GPS-ICD values named apart from WGS-84's), RINEX 2/3
observation and navigation reading and RINEX 3 writing, SP3 precise orbits, broadcast
ephemeris satellite position/velocity/clock (GPS, Galileo, BeiDou, GLONASS), pseudorange
and Doppler models with their corrections as CasADi functions, single-point positioning
(SPP) with RAIM/FDE, and a simulated constellation and measurement generator.
Uses the Earth model of `trackmodel.earth`.
"""
