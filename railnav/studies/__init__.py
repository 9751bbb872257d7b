"""Monte Carlo studies: ``railnav study CONFIG.toml``.

`config` (StudyConfig), `file` (the TOML file), `runs` (the grid expanded into runs, one run
-> one row), `execution` (serial, process pool, Dask), `store` (atomic parquet parts, resume),
`plots`, `study` (`run_study`), and `faults` (simulated satellite faults against the FDE).
"""
