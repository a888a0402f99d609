"""Compiling azgym's kernels: one decorator, and a consistent on-disk cache.

Every compiled kernel is declared with :func:`jit`: numba's ``njit`` with its result cached on
disk (``cache=True``, so only the first run on a machine pays the compile time) and numpy's error
model (a division by zero gives inf or NaN, as in numpy, and needs no check in the loop).

Installing azgym compiles its kernels (:mod:`azgym.precompile`, run by the build) into the
package's ``_compiled`` folder. The first import copies them into the folder numba caches in
(``NUMBA_CACHE_DIR``'s, or the package's ``__pycache__``) when they were compiled from the
installed sources by the running numba, so a first run loads them instead of compiling for
twenty seconds. numba checks each cached function's source by its content, so the copies load
wherever the package sits.

numba keys each cached function on its own source file only. A kernel in one
module that calls a kernel in another (``ransac.py`` → ``_kernels.py``) therefore keeps running
the old callee from the cache after the callee's file is edited, or updated by ``git pull`` in an
editable install. When this module is first imported (by the first kernel module, never by
``import azgym``), :func:`drop_stale_cache` hashes the sources of every module with kernels and,
when the hash differs from the one recorded beside the cache, deletes those modules' cache files:
only azgym's own, in azgym's own cache folders.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numba
from numba.misc.appdirs import AppDirs

from azgym.core import wrap_scalar

__all__ = ["COMPILED_FOLDER", "KERNEL_MODULES", "MANIFEST_NAME", "PACKAGE_DIR", "STAMP_NAME",
           "PRECOMPILE_SWITCH", "drop_stale_cache", "jit", "kernel_folders", "localizers_compiled",
           "numba_subfolder", "shipped_kernels", "sources_digest", "wrap_compiled"]

PACKAGE_DIR = Path(__file__).parent
KERNEL_MODULES = (
    "core.py", "errors.py", "hyperparameters.py", "jit.py", "localize/_angles.py",
    "localize/_circles.py", "localize/_kernels.py", "localize/_levenberg_marquardt.py",
    "localize/_mex_area.py", "localize/ransac_search.py",
    "localize/learned/ng_search.py", "localize/learned/distribution.py",
    "localize/learned/features.py", "localize/learned/inlier_network.py",
    "localize/learned/ng_ransac.py", "localize/learned/pose_network.py",
    "localize/learned/pose_regression.py", "localize/learned/weights.py",
    "localize/base.py", "localize/loo.py", "localize/lsq.py", "localize/mex.py",
    "localize/ransac.py", "localize/refinement.py", "localize/triplet.py", "nav/_descent.py",
    "nav/_observation.py",
    "sensing/geometry/detections.py", "sensing/geometry/direct.py", "sensing/geometry/frame.py",
    "sensing/geometry/mirrors.py", "sensing/geometry/occluders.py",
    "sensing/geometry/ordering.py", "sensing/identities.py", "sensing/image/_match.py",
    "sensing/image/_turn.py", "sensing/image/detect.py", "sensing/image/render.py",
    "sensing/labels.py", "sensing/protocol.py", "site/elements.py",
    "site/error_model.py", "site/fisheye.py", "track/_motion_check.py",
    "track/azimuth_update.py", "track/inertial_steps.py", "track/repair_fit.py",
    "track/unicycle.py", "track/unicycle_steps.py", "world/_polyline.py",
)
"""The modules (relative to the package) with compiled kernels, and every azgym module they import
from: numba compiles a kernel's global constants (label codes, row numbers) into it, so a change
to any of them must drop the cache as much as a change to a kernel."""
STAMP_NAME = "azgym-kernels.sha256"
COMPILED_FOLDER = "_compiled"
"""The package's folder of kernels compiled at installation, one subfolder per source folder."""
MANIFEST_NAME = "manifest.json"
"""The record in :data:`COMPILED_FOLDER` of the sources and the numba they were compiled by."""
PRECOMPILE_SWITCH = "AZGYM_PRECOMPILE"
"""The environment variable that, set to 0, leaves the kernels to numba's first call: the build
compiles none (:mod:`azgym.build_hook`) and a run copies none of those an installation has."""


def jit(function: Callable[..., Any] | None = None, **options: Any) -> Any:
    """``numba.njit`` with ``cache=True`` and ``error_model="numpy"`` unless told otherwise.

    Use it bare (``@jit``) or with numba's options (``@jit(inline="always")``).
    """
    options = {"cache": True, "error_model": "numpy", **options}
    if function is None:
        return numba.njit(**options)
    return numba.njit(**options)(function)


wrap_compiled = jit(inline="always")(wrap_scalar)
"""The compiled twin of :func:`azgym.core.wrap_scalar`, for kernels: wrap to (−π, π]."""


def numba_subfolder(source_dir: Path) -> str:
    """The folder numba gives a source folder's cache inside a shared cache directory.

    numba's own rule (``_CacheLocator.get_suitable_cache_subpath``): the folder's name, an
    underscore and the SHA-1 of its absolute path.
    """
    path = os.path.abspath(source_dir)
    return f"{os.path.basename(path)}_{hashlib.sha1(path.encode()).hexdigest()}"


def kernel_folders(package_dir: Path) -> list[Path]:
    """The package's folders that hold kernel modules (numba caches each folder on its own)."""
    return sorted({(package_dir / module).parent for module in KERNEL_MODULES})


def _cache_dirs(package_dir: Path) -> list[Path]:
    """The folders numba may keep azgym's cache in.

    Each kernel module's ``__pycache__``; its subfolder of ``NUMBA_CACHE_DIR`` when that is set;
    and its subfolder of the user-wide cache numba falls back to when ``__pycache__`` is not
    writable. Nothing else: other projects' caches sit in other subfolders.
    """
    folders = kernel_folders(package_dir)
    shared = [Path(os.environ["NUMBA_CACHE_DIR"])] if os.environ.get("NUMBA_CACHE_DIR") else []
    shared.append(Path(AppDirs("numba", appauthor=False).user_cache_dir))
    dirs = [folder / "__pycache__" for folder in folders]
    dirs += [root / numba_subfolder(folder) for root in shared for folder in folders]
    return sorted(dirs)


def sources_digest(package_dir: Path) -> str:
    """SHA-256 of every watched module's source: what azgym's cached kernels were compiled from."""
    digest = hashlib.sha256()
    for module in KERNEL_MODULES:
        digest.update((package_dir / module).read_bytes())
    return digest.hexdigest()


def drop_stale_cache(package_dir: Path = PACKAGE_DIR) -> bool:
    """Delete azgym's cached kernels wherever they were compiled from other sources.

    Each cache folder keeps its own record of the sources its kernels came from, so a folder
    found current is left alone, and a folder whose record cannot be written is never touched
    (numba cannot write there either). Then the kernels compiled at installation, when they
    match these sources, are copied into the folders numba will cache in (:func:`shipped_kernels`).

    Args:
        package_dir: The installed package's folder (the tests give a copy).

    Returns:
        Whether any cached kernel was deleted.
    """
    stamp = sources_digest(package_dir)
    names = {Path(module).stem for module in KERNEL_MODULES}
    dropped = False
    for folder in _cache_dirs(package_dir):
        if folder.is_dir() and _claim(folder, stamp):
            dropped |= _delete_kernels(folder, names)
    shipped = shipped_kernels(package_dir, stamp)
    for sources in kernel_folders(package_dir):
        cache = _prepare(sources, stamp)
        if cache is not None and shipped is not None:
            _seed(cache, shipped / sources.relative_to(package_dir))
    return dropped


def shipped_kernels(package_dir: Path, stamp: str) -> Path | None:
    """The package's kernels compiled at installation, if compiled from these sources by this numba.

    Args:
        package_dir: The installed package's folder.
        stamp: :func:`sources_digest` of its sources.

    Returns:
        The :data:`COMPILED_FOLDER`, or None when there is none, or its manifest names other
        sources (an edited editable installation) or another numba version (numba would ignore
        the files), or :data:`PRECOMPILE_SWITCH` is 0.
    """
    if os.environ.get(PRECOMPILE_SWITCH) == "0":
        return None
    folder = package_dir / COMPILED_FOLDER
    try:
        manifest = json.loads((folder / MANIFEST_NAME).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(manifest, dict):
        return None
    if manifest.get("sources") != stamp or manifest.get("numba") != numba.__version__:
        return None
    return folder


def _seed(cache: Path, shipped: Path) -> None:
    """Copy into ``cache`` every shipped kernel it lacks: its data files first, then its index.

    A kernel whose index is already in ``cache`` is left as it is (numba compiled or loaded it
    there). Each file is written under a temporary name and renamed, so a process starting
    alongside never reads half a file; a file that cannot be written is skipped (numba then
    compiles that kernel as usual).
    """
    try:
        files = sorted(path.name for path in shipped.iterdir())
    except OSError:
        return
    for index in (name for name in files if name.endswith(".nbi")):
        if (cache / index).exists():
            continue
        base = index[: -len(".nbi")]
        data = [name for name in files if name.startswith(base + ".") and name.endswith(".nbc")]
        for name in [*data, index]:
            if not _copy(shipped / name, cache / name):
                break


def _copy(source: Path, target: Path) -> bool:
    """Copy a file by a temporary name in the target's folder and a rename; False if it failed."""
    temporary: Path | None = None
    try:
        with tempfile.NamedTemporaryFile(dir=target.parent, prefix=".seed-", delete=False) as out:
            temporary = Path(out.name)
            out.write(source.read_bytes())
        os.replace(temporary, target)
    except OSError:
        if temporary is not None:
            temporary.unlink(missing_ok=True)
        return False
    return True


def _prepare(sources: Path, stamp: str) -> Path | None:
    """Create, with the record of ``stamp``, the folder numba will cache ``sources``' kernels in.

    Without it, a folder numba creates later (on a first run, or with a new ``NUMBA_CACHE_DIR``)
    would hold kernels but no record, and the next run would take them for stale and compile
    them all again. numba's order: the subfolder of ``NUMBA_CACHE_DIR`` when that is set, else
    the sources' ``__pycache__`` when it can be written, else the user-wide cache's subfolder.

    Returns:
        That folder, or None when none of them can be written.
    """
    if os.environ.get("NUMBA_CACHE_DIR"):
        candidates = [Path(os.environ["NUMBA_CACHE_DIR"]) / numba_subfolder(sources)]
    else:
        candidates = [sources / "__pycache__", Path(AppDirs("numba", appauthor=False)
                                                     .user_cache_dir) / numba_subfolder(sources)]
    for folder in candidates:
        if folder.is_dir() and os.access(folder, os.W_OK):
            return folder
        try:
            folder.mkdir(parents=True)
            (folder / STAMP_NAME).write_text(stamp)
        except OSError:
            continue
        return folder
    return None


def _claim(folder: Path, stamp: str) -> bool:
    """Record ``stamp`` in the folder; True if it held another (or none): its kernels are stale."""
    record = folder / STAMP_NAME
    try:
        if record.is_file() and record.read_text() == stamp:
            return False
        record.write_text(stamp)
    except OSError:
        return False
    return True


def _delete_kernels(folder: Path, names: set[str]) -> bool:
    """Delete the folder's cache files of azgym's modules; True if any was deleted."""
    dropped = False
    for path in folder.glob("*.nb[ic]"):  # numba names them <module>.<function>-<line>...
        if path.name.split(".")[0] in names:
            try:
                path.unlink()
                dropped = True
            except OSError:
                continue
    return dropped


def localizers_compiled(package_dir: Path = PACKAGE_DIR) -> bool:
    """Whether the localizers' kernels are in numba's cache (False: the next run compiles them).

    Looks for the index of the reference localizer's kernel, the last one a first run compiles,
    where numba will look: only in ``NUMBA_CACHE_DIR`` when that is set (numba then keeps its
    cache there and nowhere else), else in the package's ``__pycache__`` and the user-wide cache.
    """
    folders = _cache_dirs(package_dir)
    if os.environ.get("NUMBA_CACHE_DIR"):
        root = Path(os.environ["NUMBA_CACHE_DIR"])
        folders = [folder for folder in folders if folder.is_relative_to(root)]
    return any(folder.is_dir() and any(folder.glob("ransac._ransac_frame-*.nbi"))
               for folder in folders)


drop_stale_cache()
