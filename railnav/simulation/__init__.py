"""Simulation: what a simulated trip is made of.

Owns speed profiles (`profiles`), the exact trajectory and ideal IMU (`truth`), named
scenarios (`scenarios`) and simulated trips with their sensors, held in memory (`trip`) or
produced segment by segment (`trip_stream`).
"""
