"""Keep numba's on-disk cache of the compiled kernels consistent across modules.

numba keys each cached function on the timestamp of its own source file only. A kernel in
``ransac.py`` that calls one in ``_kernels.py`` therefore keeps running the old ``_kernels`` code,
from the cache, after ``_kernels.py`` is edited (or updated by ``git pull`` in an editable install).
At import, :func:`drop_stale_cache` hashes the sources of every module with cached kernels and
deletes the cache files when the hash differs from the one recorded beside them.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

KERNEL_MODULES = ("_kernels", "base", "loo", "lsq", "mex", "ransac", "refinement", "triplet")
"""The modules of this package whose numba functions use ``cache=True``."""


def _cache_dirs(package_dir: Path) -> list[Path]:
    dirs = [package_dir / "__pycache__"]
    configured = os.environ.get("NUMBA_CACHE_DIR")
    if configured:
        dirs.append(Path(configured))
    return dirs


def drop_stale_cache(package_dir: Path | None = None) -> bool:
    """Delete numba's cache files of the kernels if any kernel source changed; True if it did."""
    package_dir = package_dir or Path(__file__).parent
    digest = hashlib.sha256()
    for name in KERNEL_MODULES:
        digest.update((package_dir / f"{name}.py").read_bytes())
    stamp = digest.hexdigest()
    dropped = False
    for folder in _cache_dirs(package_dir):
        record = folder / "azgym-kernels.sha256"
        try:
            if record.is_file() and record.read_text() == stamp:
                continue
            for path in folder.rglob("*.nb[ic]"):
                if path.name.split(".")[0] in KERNEL_MODULES:
                    path.unlink()
                    dropped = True
            folder.mkdir(parents=True, exist_ok=True)
            record.write_text(stamp)
        except OSError:
            continue  # a read-only install: numba then caches elsewhere or not at all
    return dropped
