"""railnav — track-constrained navigation of rail vehicles (the application).

Assembles the four library packages into scenarios (truth, sensors, faults), the
navigator (constrained, unconstrained and GNSS-only filters), the ``railnav`` command
line, plots and studies. Everything the CLI does is a public function here first.
"""
