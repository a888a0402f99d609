"""The kernel cache: an edited kernel module drops azgym's cached kernels, and nobody else's."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from azgym.jit import KERNEL_MODULES, drop_stale_cache, localizers_compiled, numba_subfolder


def fake_package(root: Path) -> Path:
    """A copy of the package's kernel modules' layout under ``root``, each a one-line file."""
    for module in KERNEL_MODULES:
        (root / module).parent.mkdir(parents=True, exist_ok=True)
        (root / module).write_text(f"# {module}\n")
    return root


@pytest.fixture
def package_with_cache(tmp_path, monkeypatch) -> tuple[Path, Path]:
    """A fake package and its localize/__pycache__, with no shared numba cache set."""
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    cache = fake_package(tmp_path) / "localize" / "__pycache__"
    cache.mkdir()
    return tmp_path, cache


def test_editing_a_kernel_module_drops_the_whole_kernel_cache(package_with_cache):
    # numba keys a cached function on its own file only; a caller in another module would keep
    # running an edited callee's old code. drop_stale_cache hashes every kernel module instead.
    tmp_path, cache = package_with_cache
    assert drop_stale_cache(tmp_path) is False  # nothing cached yet; the hash is recorded
    (cache / "ransac._search-10.py311.nbi").write_text("index")
    (cache / "other.f-1.py311.nbi").write_text("not ours")
    assert drop_stale_cache(tmp_path) is False  # sources unchanged: the cache is kept
    assert (cache / "ransac._search-10.py311.nbi").exists()
    (tmp_path / "localize" / "_kernels.py").write_text("# edited\n")
    assert drop_stale_cache(tmp_path) is True
    assert not (cache / "ransac._search-10.py311.nbi").exists()
    assert (cache / "other.f-1.py311.nbi").exists()


def test_with_a_shared_cache_folder_only_azgyms_own_subfolders_are_touched(tmp_path, monkeypatch):
    package = fake_package(tmp_path / "site-packages" / "azgym")
    shared = tmp_path / "numba-cache"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(shared))
    ours = shared / numba_subfolder(package / "localize")
    theirs = shared / "elsewhere" / "project"
    for folder in (ours, theirs):
        folder.mkdir(parents=True)
        (folder / "ransac._search-10.py311.nbi").write_text("index")
    assert drop_stale_cache(package) is True  # no hash recorded yet: treated as changed
    assert not (ours / "ransac._search-10.py311.nbi").exists()
    assert (theirs / "ransac._search-10.py311.nbi").exists()  # another project's ransac.py


def test_a_cache_folder_numba_has_yet_to_create_is_made_with_its_record(tmp_path, monkeypatch):
    # A new NUMBA_CACHE_DIR: numba would create the folder on the first compile, without the
    # record, and the next run would take the fresh kernels for stale and compile them again.
    from azgym.jit import STAMP_NAME

    package = fake_package(tmp_path / "site-packages" / "azgym")
    shared = tmp_path / "empty-cache"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(shared))
    assert drop_stale_cache(package) is False  # nothing there: nothing dropped
    ours = {shared / numba_subfolder((package / module).parent) for module in KERNEL_MODULES}
    for folder in ours:
        assert (folder / STAMP_NAME).is_file()
        (folder / "ransac._search-10.py311.nbi").write_text("compiled on the first run")
    assert drop_stale_cache(package) is False  # the second run keeps the first run's kernels
    assert all((folder / "ransac._search-10.py311.nbi").exists() for folder in ours)


def test_the_shared_cache_subfolder_is_numbas_own():
    from numba.core.caching import _CacheLocator

    source = "/some/where/azgym/localize/ransac.py"
    assert numba_subfolder(Path(source).parent) == _CacheLocator.get_suitable_cache_subpath(source)


def test_the_compiled_wrap_is_the_python_wrap_bit_for_bit():
    import math

    import numpy as np

    from azgym.core import wrap_angle, wrap_scalar
    from azgym.jit import wrap_compiled

    rng = np.random.default_rng(0)
    edges = [math.pi, -math.pi, np.nextafter(math.pi, 4.0), np.nextafter(-math.pi, 0.0),
             np.nextafter(-math.pi, -4.0), 3 * math.pi, -3 * math.pi, 0.0, -0.0, 1e6]
    angles = np.concatenate([edges, rng.uniform(-20, 20, 2000), rng.uniform(-4, 4, 2000)])
    array = wrap_angle(angles)
    for k, angle in enumerate(angles):
        expected = wrap_scalar(float(angle))
        assert wrap_compiled(float(angle)) == expected == array[k]
        assert -math.pi < expected <= math.pi
        if -math.pi < angle <= math.pi:
            assert expected == angle  # in range: untouched, to the last bit


def test_non_finite_angles_stay_as_they_are_and_huge_ones_wrap_alike():
    import math

    import numpy as np

    from azgym.core import wrap_angle, wrap_scalar
    from azgym.jit import wrap_compiled

    for angle in (math.nan, math.inf, -math.inf):
        forms = (wrap_scalar(angle), wrap_compiled(angle), wrap_angle(np.array([angle]))[0])
        assert all(math.isnan(f) for f in forms) if math.isnan(angle) else set(forms) == {angle}
    for angle in (1e300, -1e20, 1e13, -7.0 * 1e12):
        expected = wrap_scalar(angle)
        assert -math.pi < expected <= math.pi
        assert wrap_compiled(angle) == expected == wrap_angle(np.array([angle]))[0]


def test_a_cache_folder_whose_record_cannot_be_written_is_never_touched(package_with_cache,
                                                                         monkeypatch):
    # A read-only install: deleting there on every import would only cost recompiles.
    from azgym.jit import STAMP_NAME

    tmp_path, cache = package_with_cache
    (cache / "ransac._search-10.py311.nbi").write_text("index")
    write_text = Path.write_text

    def read_only(self, *args, **kwargs):
        if self.name == STAMP_NAME:
            raise PermissionError(f"read-only: {self}")
        return write_text(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", read_only)
    for _ in range(3):
        assert drop_stale_cache(tmp_path) is False
    assert (cache / "ransac._search-10.py311.nbi").exists()


def test_with_numba_cache_dir_set_only_that_cache_says_whether_the_kernels_are_compiled(
        tmp_path, monkeypatch):
    """numba keeps its cache only in NUMBA_CACHE_DIR when it is set: an empty one means the next
    run compiles (and says so), whatever the package's own __pycache__ holds."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert not localizers_compiled()


def ship(package: Path, kernels: dict[str, list[str]], **manifest: str) -> None:
    """Give a fake package kernels compiled at installation: folder → file names, and a manifest
    of its own sources and this numba unless told otherwise."""
    import json

    import numba

    from azgym.jit import COMPILED_FOLDER, MANIFEST_NAME, sources_digest

    shipped = package / COMPILED_FOLDER
    for folder, names in kernels.items():
        (shipped / folder).mkdir(parents=True, exist_ok=True)
        for name in names:
            (shipped / folder / name).write_text(f"shipped {name}")
    record = {"sources": sources_digest(package), "numba": numba.__version__, **manifest}
    (shipped / MANIFEST_NAME).write_text(json.dumps(record))


RANSAC = ["ransac._frame-9.py311.nbi", "ransac._frame-9.py311.1.nbc",
          "ransac._frame-9.py311.2.nbc"]
MOTION = ["_motion_check.fault-3.py311.nbi", "_motion_check.fault-3.py311.1.nbc"]


@pytest.fixture
def installed(tmp_path, monkeypatch) -> tuple[Path, Path]:
    """A fake installed package with an empty NUMBA_CACHE_DIR, as a fresh installation runs."""
    package = fake_package(tmp_path / "site-packages" / "azgym")
    shared = tmp_path / "empty-cache"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(shared))
    return package, shared


def test_kernels_compiled_at_installation_are_copied_where_numba_looks(installed):
    package, shared = installed
    ship(package, {"localize": RANSAC, "track": MOTION})
    drop_stale_cache(package)
    localize = shared / numba_subfolder(package / "localize")
    track = shared / numba_subfolder(package / "track")
    for folder, names in ((localize, RANSAC), (track, MOTION)):
        for name in names:
            assert (folder / name).read_text() == f"shipped {name}"
    assert not list(shared.rglob(".seed-*"))  # no temporary file left behind
    assert localizers_compiled(package) is False  # (no file of that name was shipped here)


def test_a_kernel_numba_already_cached_is_left_as_it_is(installed):
    package, shared = installed
    ship(package, {"localize": RANSAC})
    drop_stale_cache(package)  # the folder is made, with its record, and seeded
    localize = shared / numba_subfolder(package / "localize")
    (localize / RANSAC[0]).write_text("numba's own index, with more signatures")
    (localize / RANSAC[1]).write_text("numba's own data")
    drop_stale_cache(package)
    assert (localize / RANSAC[0]).read_text() == "numba's own index, with more signatures"
    assert (localize / RANSAC[1]).read_text() == "numba's own data"


@pytest.mark.parametrize("manifest", [{"sources": "0" * 64}, {"numba": "0.1.0"}])
def test_kernels_compiled_from_other_sources_or_by_another_numba_are_not_copied(installed,
                                                                               manifest):
    # An editable installation edited since it was installed, or numba upgraded: the files
    # would at best be ignored by numba, at worst be the old kernels' code.
    package, shared = installed
    ship(package, {"localize": RANSAC}, **manifest)
    drop_stale_cache(package)
    assert not list(shared.rglob("*.nb[ic]"))


@pytest.mark.parametrize("manifest", ["not json", "[1, 2]", ""])
def test_an_unreadable_manifest_means_no_shipped_kernels(installed, manifest):
    from azgym.jit import COMPILED_FOLDER, MANIFEST_NAME, shipped_kernels, sources_digest

    package, shared = installed
    ship(package, {"localize": RANSAC})
    (package / COMPILED_FOLDER / MANIFEST_NAME).write_text(manifest)
    assert shipped_kernels(package, sources_digest(package)) is None
    drop_stale_cache(package)
    assert not list(shared.rglob("*.nb[ic]"))


def test_a_kernel_whose_files_cannot_be_copied_is_left_for_numba_to_compile(installed,
                                                                          monkeypatch):
    import os

    package, shared = installed
    ship(package, {"localize": RANSAC})
    replace = os.replace

    def full_disk(source, target):
        if str(target).endswith(".2.nbc"):
            raise OSError(28, "No space left on device")
        return replace(source, target)

    monkeypatch.setattr(os, "replace", full_disk)
    drop_stale_cache(package)
    localize = shared / numba_subfolder(package / "localize")
    assert not (localize / RANSAC[0]).exists()  # no index pointing at a missing data file
    assert not list(localize.glob(".seed-*"))


def test_the_build_collects_every_kernel_folder_with_its_manifest(tmp_path):
    import json

    import numba

    from azgym.jit import MANIFEST_NAME, shipped_kernels, sources_digest
    from azgym.precompile import collect

    package = fake_package(tmp_path / "stage" / "azgym")
    cache = tmp_path / "numba-cache"
    for folder, names in (("localize", RANSAC), ("track", MOTION)):
        compiled = cache / numba_subfolder(package / folder)
        compiled.mkdir(parents=True)
        for name in [*names, "azgym-kernels.sha256"]:
            (compiled / name).write_text(name)
    out = tmp_path / "build" / "azgym" / "_compiled"
    (out / "stale").mkdir(parents=True)  # a previous build's folder is replaced as a whole
    assert collect(cache, out, package) == 2
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == sorted(
        [MANIFEST_NAME, *(f"localize/{n}" for n in RANSAC), *(f"track/{n}" for n in MOTION)])
    assert json.loads((out / MANIFEST_NAME).read_text()) == {
        "sources": sources_digest(package), "numba": numba.__version__}
    installed = tmp_path / "site-packages" / "azgym"
    shutil.copytree(package, installed)
    shutil.copytree(out, installed / "_compiled")
    assert shipped_kernels(installed, sources_digest(installed)) == installed / "_compiled"


FIRST_RUN = """
import numpy as np
from numba.core import event

import azgym

compiled = []
class Record(event.Listener):
    def on_start(self, e):
        compiled.append(e.data["dispatcher"].py_func.__module__)
    def on_end(self, e):
        pass
event.register("numba:compile", Record())
beacons = azgym.load_scenario("warehouse-small").beacons
ids = beacons.ids[:6]
bearings = np.arctan2(beacons.xyz[:6, 1] - 5.0, beacons.xyz[:6, 0] - 8.0) - 0.4
estimate = azgym.make_localizer("ransac").localize(azgym.Measurements(ids, bearings), beacons)
assert estimate.ok, estimate
print(len([module for module in compiled if module.startswith("azgym")]))
"""


def test_a_fresh_installation_runs_its_first_frame_without_compiling(tmp_path):
    # What makes a first azgym bench take seconds, not half a minute: the kernels compiled by
    # the installation load from an empty NUMBA_CACHE_DIR.
    from azgym.jit import PACKAGE_DIR, shipped_kernels, sources_digest

    if shipped_kernels(PACKAGE_DIR, sources_digest(PACKAGE_DIR)) is None:
        pytest.skip("this installation has no kernels compiled from its sources (installed "
                    "with AZGYM_PRECOMPILE=0, or edited since)")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty")}
    done = subprocess.run([sys.executable, "-c", FIRST_RUN], env=env, capture_output=True,
                          text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "0"


def test_the_switch_leaves_the_kernels_to_numbas_first_call(installed, monkeypatch):
    from azgym import build_hook
    from azgym.jit import PRECOMPILE_SWITCH

    assert build_hook.PRECOMPILE_SWITCH == PRECOMPILE_SWITCH  # the build reads the same name
    package, shared = installed
    ship(package, {"localize": RANSAC})
    monkeypatch.setenv(PRECOMPILE_SWITCH, "0")
    drop_stale_cache(package)
    assert not list(shared.rglob("*.nb[ic]"))
    monkeypatch.setenv(PRECOMPILE_SWITCH, "1")
    drop_stale_cache(package)
    assert len(list(shared.rglob("*.nb[ic]"))) == len(RANSAC)
