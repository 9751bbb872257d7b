"""Reproductions of the source papers: ``railnav reproduce NAME``.

`common` (the registry and the "ours vs paper" result), `paper2017`, and `anomaly2021` with
its own filter (`anomaly_filter`), linear models (`anomaly_models`) and simulator
(`anomaly_sim`).
"""
