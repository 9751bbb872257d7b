"""The repository carries what it needs: no path into a folder outside it (issue 18).

A user has a clone or a wheel, never the sibling folders the project was developed beside,
so no tracked text file may name an absolute path into them or climb out of the repository
to reach them. Reference: the list of files git tracks (`git ls-files`), or a walk of the
tree when the repository is not a git checkout (an unpacked source archive).
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: Absolute paths into the development machine's work folder, and relative climbs into a
#: sibling "shared" folder (written in pieces so that this file does not match itself).
OUTSIDE = re.compile("/" + "work/" + r"|\.\./" + "shared" + r"|parent\s*/\s*['\"]" + "shared")
#: Generated or binary content that is not ours to check.
SKIP_SUFFIXES = {".png", ".parquet", ".sp3", ".rnx", ".pyc"}


def _tracked_files() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True,
                             check=True).stdout
        return [REPO / line for line in out.splitlines()]
    except (OSError, subprocess.CalledProcessError):
        return [p for p in REPO.rglob("*") if p.is_file() and ".git" not in p.parts]


def test_issue18_no_path_outside_the_repository():
    offenders = []
    for path in _tracked_files():
        if path.suffix in SKIP_SUFFIXES or not path.is_file():
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        for number, line in enumerate(text.splitlines(), start=1):
            if OUTSIDE.search(line):
                offenders.append(f"{path.relative_to(REPO)}:{number}: {line.strip()[:80]}")
    assert not offenders, "\n".join(offenders)
