"""The kernel cache: an edited kernel module drops azgym's cached kernels, and nobody else's."""

from __future__ import annotations

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
