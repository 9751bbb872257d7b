"""What an SP3 header declares, checked against the records the file holds.

SP3-c/d line 1 gives the number of epochs (columns 33-39) and the ``+`` lines the number
of satellites and their list (17 three-character codes per line from column 10; SP3-d
§2, Hilla 2016); every epoch then holds one ``P`` record per listed satellite. A file cut
at a record boundary reads without a framing error; only these declarations tell. As for
RINEX observations (`gnss_obs._obs_checks`), what they contradict is **one warning per
file with the counts**, and what is there is read: the epochs present are exact, and a
time outside the file's coverage is an error where it is used (`gnss_obs.sp3.Sp3`).
"""
from __future__ import annotations

import logging
import os

import pandas as pd

__all__ = ["check_declared", "declared_satellites"]

log = logging.getLogger("gnss_obs.sp3")

_N_EPOCHS_COLUMNS = (32, 39)
_N_SATS_COLUMNS = (1, 6)
_SATS_START = 9
_SAT_WIDTH = 3
_SATS_PER_LINE = 17
_HEADER_LINES = 40
_NAMED = 5


def _int(text: str) -> int | None:
    text = text.strip()
    return int(text) if text.isdigit() else None


def declared_satellites(lines: list[bytes]) -> tuple[int | None, list[str]]:
    """Number of satellites of the first ``+`` line and the codes of all ``+`` lines."""
    plus = [ln.decode("ascii", errors="replace") for ln in lines[:_HEADER_LINES]
            if ln[:1] == b"+" and ln[1:2] != b"+"]
    if not plus:
        return None, []
    codes = []
    for text in plus:
        for k in range(_SATS_PER_LINE):
            start = _SATS_START + _SAT_WIDTH * k
            code = text[start:start + _SAT_WIDTH]
            if code.strip() and code.strip() != "0":
                codes.append(code[0] + code[1:].replace(" ", "0"))
    return _int(plus[0][slice(*_N_SATS_COLUMNS)]), codes


def check_declared(lines: list[bytes], table: pd.DataFrame, n_epochs: int,
                   path: str | os.PathLike) -> list[str]:
    """Warn once when the file holds fewer epochs or satellites than its header declares.

    Parameters
    ----------
    lines : list of bytes
        The file's lines.
    table : pandas.DataFrame
        The position records read (`gnss_obs.sp3.SP3_COLUMNS`).
    n_epochs : int
        Epoch records (``*`` lines) read.
    path : str or os.PathLike

    Returns
    -------
    list of str
        The contradictions found (also logged as one warning).
    """
    first = lines[0].decode("ascii", errors="replace")
    problems = []
    declared_epochs = _int(first[slice(*_N_EPOCHS_COLUMNS)])
    if declared_epochs is not None and n_epochs < declared_epochs:
        problems.append(f"line 1 declares {declared_epochs} epochs, the file holds {n_epochs}")
    n_sats, codes = declared_satellites(lines)
    present = set(table["sv"])
    absent = [c for c in codes if c not in present]
    if absent:
        more = ", ..." if len(absent) > _NAMED else ""
        problems.append(f"{len(absent)} of the {len(codes)} listed satellites have no "
                        f"position record ({', '.join(absent[:_NAMED])}{more})")
    if n_sats is not None and len(table):
        per_epoch = table.groupby("gps_time_s")["sv"].size().to_numpy()
        short = int((per_epoch < n_sats).sum())
        if short:
            problems.append(f"{short} of {per_epoch.size} epochs hold fewer than the "
                            f"{n_sats} declared satellites (as few as {int(per_epoch.min())})")
    if problems:
        log.warning("%s: fewer records than the header declares (%s): truncated file?",
                    os.fspath(path), "; ".join(problems))
    return problems
