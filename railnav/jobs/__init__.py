"""Jobs: one ``railnav run`` from sensors to output files, as public functions.

`run` (`run_simulated`, `run_files`, `write_run`), `tracks` (several candidate tracks),
`baro` (``--baro``), `spp` (``railnav spp``: `spp_files`). The CLI commands are thin
layers over these; a notebook calls them the
same way with the same defaults.
"""
