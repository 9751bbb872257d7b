"""Jobs: one ``railnav run`` from sensors to output files, as public functions.

`run` (`run_simulated`, `run_files`, `write_run`), `tracks` (several candidate tracks),
`baro` (``--baro``). The CLI command is a thin layer over these; a notebook calls them the
same way with the same defaults.
"""
