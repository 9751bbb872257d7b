"""Jobs: what each ``railnav`` command does, as public functions.

`run` (`run_simulated`, `run_files`, `write_run`), `tracks` (several candidate tracks),
`network` and `network_sim` (track networks: `run_files_network`, `run_simulated_route`),
`baro` (``--baro``), `export` (``--export``), `spp` (``railnav spp``: `spp_files`),
`simulated_files` (``railnav simulate``'s files: `write_simulated_trip`), `survey`
(``railnav track fit``: `fit_survey`). The CLI commands are thin layers over these; a
notebook calls them the same way with the same defaults
(``tests/railnav/commands/test_api_parity.py`` checks every option's).
"""
