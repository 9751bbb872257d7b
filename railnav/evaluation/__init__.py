"""Evaluation: errors against a truth or reference, their statistics and plots.

Owns navigation errors and summaries (`metrics`, `running_stats`), the run plots (`plots`,
`track_plots`, `outage_plots`), the barometric check against the track (`baro`) and
single-point accuracy against a reference trajectory (`spp_accuracy`).
"""
