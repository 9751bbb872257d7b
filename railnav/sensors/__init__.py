"""Sensors: railway sensor files beyond GNSS and the IMU, read and written.

Owns the odometer (wheel tachometer: speed, or pulse counts with a wheel circumference;
`odometer`) and balise (point anchors passed at known positions; `balises`) records: their
CSV readers with located one-line errors, the tables the filters take, and the writers
``railnav simulate`` uses. GNSS fixes are `gnss_obs.fixes`'s, IMU logs `strapdown.imu_log`'s.
"""
