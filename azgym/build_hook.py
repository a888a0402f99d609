"""The installation's build step that compiles azgym's kernels (pyproject.toml's ``cmdclass``).

setuptools' ``build_py``, then :mod:`azgym.precompile` on a copy of the package laid out as it
is installed (the repository's ``envs/`` as ``azgym/site/scenarios``), in a process of the build's
own Python with an empty numba cache. The kernels land in ``azgym/_compiled`` of the wheel, or
of the source tree for an editable installation (which imports the package from there).

A failed compile does not fail the installation: azgym then compiles its kernels on the first
run, as numba does, and the build says so. Setting ``AZGYM_PRECOMPILE=0`` skips the step
(:data:`azgym.jit.PRECOMPILE_SWITCH`, which this module cannot import: it runs before azgym is
installed).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from setuptools.command.build_py import build_py

__all__ = ["BuildPy", "PRECOMPILE_SWITCH", "PRECOMPILE_TIMEOUT"]

PRECOMPILE_SWITCH = "AZGYM_PRECOMPILE"
"""Set to 0, the build compiles no kernel (the same name as ``azgym.jit.PRECOMPILE_SWITCH``)."""
PRECOMPILE_TIMEOUT = 1800.0
"""Seconds the compile may take before the build gives up on it (it takes about two minutes)."""
_ROOT = Path(__file__).resolve().parent.parent
_SKIPPED = shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc", "_compiled", ".*")


class BuildPy(build_py):
    """``build_py``, then the kernels compiled into the package's ``_compiled`` folder."""

    def run(self) -> None:
        """Build the package's Python files, then compile its kernels."""
        super().run()
        if os.environ.get(PRECOMPILE_SWITCH) == "0":
            return
        if self.editable_mode:
            out = _ROOT / "azgym" / "_compiled"
        else:
            out = Path(self.build_lib).resolve() / "azgym" / "_compiled"
        _precompile(out)


def _precompile(out: Path) -> None:
    """Compile the kernels of a copy of the sources into ``out``; say so if that failed."""
    with tempfile.TemporaryDirectory(prefix="azgym-build-") as folder:
        stage = Path(folder)
        shutil.copytree(_ROOT / "azgym", stage / "azgym", ignore=_SKIPPED)
        shutil.copytree(_ROOT / "envs", stage / "azgym" / "site" / "scenarios", ignore=_SKIPPED)
        (stage / "numba-cache").mkdir()
        path = [str(stage), *(entry for entry in sys.path if entry)]
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(path),
               "NUMBA_CACHE_DIR": str(stage / "numba-cache"), "MPLBACKEND": "Agg"}
        try:
            done = subprocess.run([sys.executable, "-m", "azgym.precompile", str(out)],
                                  cwd=stage, env=env, timeout=PRECOMPILE_TIMEOUT, check=False,
                                  capture_output=True, text=True)
        except subprocess.TimeoutExpired:
            print(f"azgym: compiling the kernels took over {PRECOMPILE_TIMEOUT:.0f} s; the "
                  "first run will compile them", file=sys.stderr)
            return
    if done.returncode != 0:
        print(f"azgym: compiling the kernels failed (the first run will compile them):\n"
              f"{done.stdout[-2000:]}{done.stderr[-4000:]}", file=sys.stderr)
    else:
        print(done.stdout.strip().splitlines()[-1] if done.stdout.strip() else "")
