"""Network folders kept on disk as loaded, so that a second run does not integrate their
tracks again.

Reading a network folder (`trackmodel.network_io.read_network`) integrates every
netelement's track (`trackmodel.integrated`: an ODE per curved section): 0.55–0.8 s for the
Brussels network's 74 netelements, a third of a 15-min fix log's whole run. The loaded
`trackmodel.network.Network` is pickled under the distribution's cache root (the one of
the compiled libraries, `ekf.library_cache`: ``$RAILNAV_CACHE_DIR``, else the user cache
directory), in ``networks/<key>.pickle``; unpickling takes a few milliseconds.

* **Key.** SHA-256 of every file of the folder (relative name and bytes), of the source
  of `trackmodel` (the code that builds a `Network`) and of the Python and NumPy versions
  (the pickle's readers), so an edited file or a changed geometry model misses the cache
  and the folder is read again.
* **Writes** go to a temporary file in the cache directory, moved into place with
  ``os.replace``; a reader never sees half a file.
* **Failures never change a result:** an unreadable or stale pickle, or a cache directory
  that cannot be written, falls back to reading the folder (logged at debug level).
* **No eviction:** one file per folder content (0.2 MB for the Brussels network); delete
  the ``networks`` directory to clear it.
"""
from __future__ import annotations

import functools
import hashlib
import logging
import os
import pickle
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from ekf.library_cache import cache_root

__all__ = ["cached_network_folder", "network_cache_dir"]

log = logging.getLogger(__name__)

#: Subfolder of the cache root for loaded networks.
SUBFOLDER = "networks"


def network_cache_dir() -> Path:
    """``$RAILNAV_CACHE_DIR/networks`` if the variable is set, else the user cache
    directory's ``railnav/networks`` (`ekf.library_cache.cache_root`)."""
    return cache_root() / SUBFOLDER


@functools.lru_cache(maxsize=1)
def _code_digest() -> str:
    """SHA-256 of `trackmodel`'s source files (what a pickled `Network` was built by) and
    of the Python and NumPy versions."""
    import numpy
    import trackmodel
    digest = hashlib.sha256(f"{sys.version}|{numpy.__version__}".encode())
    for path in sorted(Path(trackmodel.__file__).parent.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _folder_key(folder: Path) -> str:
    digest = hashlib.sha256(_code_digest().encode())
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        digest.update(path.relative_to(folder).as_posix().encode() + b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()[:32]


def cached_network_folder(folder: Path, load: Callable[[Path], object], *,
                          cache_dir: Path | None = None):
    """`load(folder)`, or the same network from the cache (module docstring).

    Parameters
    ----------
    folder : Path
        A network folder (`trackmodel.network_io.write_network`'s layout).
    load : callable
        Reads the folder (`trackmodel.network_routes.load_network`); its errors propagate.
    cache_dir : Path, optional
        Default `network_cache_dir`.

    Returns
    -------
    trackmodel.network.Network
    """
    directory = network_cache_dir() if cache_dir is None else Path(cache_dir)
    try:
        target = directory / f"{_folder_key(Path(folder))}.pickle"
    except OSError as exc:
        log.debug("network cache: %s not hashed (%s); reading it", folder, exc)
        return load(folder)
    if target.is_file():
        try:
            with open(target, "rb") as f:
                return pickle.load(f)
        except Exception as exc:                    # a truncated or foreign file
            log.debug("network cache: %s unreadable (%s); reading %s", target, exc, folder)
    network = load(folder)
    _write(network, directory, target)
    return network


def _write(network, directory: Path, target: Path) -> None:
    """Pickle `network` to `target` through a temporary file; on any failure (a directory
    that cannot be written, an object that cannot be pickled) nothing is left behind."""
    tmp = None
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=directory, suffix=".tmp", delete=False) as f:
            tmp = f.name
            pickle.dump(network, f, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, target)
    except Exception as exc:                        # the run goes on without the cache
        log.debug("network cache: %s not written (%s)", directory, exc)
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
