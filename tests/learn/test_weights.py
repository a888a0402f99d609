"""Model files: a sound one loads back as written; each hostile one is refused, before any use,
with a ModelFileError naming the file and the problem, never a crash, an allocation its header
asks for, or code run from a pickle."""

from __future__ import annotations

import io
import json
import re
import warnings
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from azgym.errors import InvalidInputError, ModelFileError
from azgym.localize.learned.weights import FORMAT, array_shapes, load_weights, save_weights

LAYOUT = "test-features-1"
ARCHITECTURE = {"kind": "deepsets-context-1", "inputs": 5, "hidden": 4}


def sound_arrays(seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {name: rng.normal(size=shape) for name, shape in array_shapes(ARCHITECTURE).items()}


def sound_manifest(**changes) -> dict:
    manifest = {"format": FORMAT, "model": "ng-ransac", "azgym_version": "0.2.0",
                "architecture": ARCHITECTURE, "feature_layout": LAYOUT,
                "training": {"seed": 3, "epochs": 2}}
    manifest.update(changes)
    return manifest


def npy(array: np.ndarray, allow_pickle: bool = False) -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, array, allow_pickle=allow_pickle)
    return buffer.getvalue()


def write_archive(path: Path, members: dict[str, bytes]) -> Path:
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return path


def model_file(path: Path, arrays: dict | None = None, manifest: object = None,
               extra: dict[str, bytes] | None = None) -> Path:
    """A model file as save_weights writes it, with whatever arrays and manifest given."""
    arrays = sound_arrays() if arrays is None else arrays
    manifest = sound_manifest() if manifest is None else manifest
    members = {f"{name}.npy": npy(np.asarray(value)) for name, value in arrays.items()}
    if not isinstance(manifest, bytes):
        manifest = npy(np.array(json.dumps(manifest)))
    members["manifest.npy"] = manifest
    return write_archive(path, {**members, **(extra or {})})


def sound(path: Path) -> Path:
    save_weights(path, "ng-ransac", sound_arrays(), sound_manifest())
    return path


def truncated(path: Path) -> Path:
    data = sound(path).read_bytes()
    path.write_bytes(data[:len(data) // 2])
    return path


def damaged(path: Path) -> Path:
    data = bytearray(sound(path).read_bytes())
    start = data.index(b"\x93NUMPY") + 140  # inside W1's data (stored, not compressed)
    data[start:start + 8] = bytes(8 * [0x7f])
    path.write_bytes(bytes(data))
    return path


def raw_npy(shape: tuple[int, ...], data: bytes) -> bytes:
    """An .npy member of float64 claiming ``shape``, followed by ``data``."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buffer, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return buffer.getvalue() + data


def with_bytes(data: bytes) -> Callable[[Path], Path]:
    def build(path: Path) -> Path:
        path.write_bytes(data)
        return path
    return build


def duplicate_member(path: Path) -> Path:
    model_file(path)
    with warnings.catch_warnings(), zipfile.ZipFile(path, "a") as archive:
        warnings.simplefilter("ignore")  # zipfile warns of the duplicate it writes
        archive.writestr("W1.npy", npy(np.ones((5, 4))))
    return path


def without(*names: str) -> dict:
    return {key: value for key, value in sound_arrays().items() if key not in names}


def with_array(name: str, value: object) -> dict:
    return {**sound_arrays(), name: value}


def pickled(marker: Path) -> Callable[[Path], Path]:
    """A weight stored as a pickled object array whose unpickling would create ``marker``."""
    class Payload:
        def __reduce__(self):
            return open, (str(marker), "w")

    def build(path: Path) -> Path:
        bomb = np.empty(1, dtype=object)
        bomb[0] = Payload()
        return model_file(path, extra={"W1.npy": npy(bomb, allow_pickle=True)})
    return build


def oversized(path: Path) -> Path:
    with path.open("wb") as handle:
        handle.truncate(17 * 2**20)
    return path


HOSTILE: dict[str, tuple[Callable[[Path], Path], str]] = {
    "missing": (lambda path: path, "no such model file"),
    "a-folder": (lambda path: path.mkdir() or path, "cannot read the model file"),
    "empty": (with_bytes(b""), r"not a model file \(not an \.npz zip archive\)"),
    "text": (with_bytes(b"W1 = [1, 2]\n"), r"not a model file \(not an \.npz zip archive\)"),
    "oversized": (oversized, r"17825792 bytes, larger than a model file may be \(16 MiB\)"),
    "truncated": (truncated, r"truncated \(a zip archive without its end\)"),
    "damaged": (damaged, "damaged archive: Bad CRC-32 for file 'W1.npy'"),
    "not-npy-member": (lambda path: model_file(path, extra={"notes.txt": b"hi"}),
                       "member 'notes.txt' is not an .npy array"),
    "bad-npy-header": (lambda path: model_file(path, extra={"W1.npy": b"\x93NUMPY\x01\x00x"}),
                       "member 'W1.npy' is not a valid .npy array"),
    "short-data": (lambda path: model_file(path, extra={"W1.npy": raw_npy((5, 4), bytes(120))}),
                   "member 'W1.npy' holds 120 bytes of data, its header says 160"),
    "huge-header": (lambda path: model_file(path, extra={"W1.npy": raw_npy((10**9,), bytes(8))}),
                    r"member 'W1.npy' claims shape \(1000000000,\), larger than 8 MiB"),
    "duplicate-member": (duplicate_member, "a member is listed twice"),
    "no-manifest": (lambda path: write_archive(path, {"W1.npy": npy(np.zeros((5, 4)))}),
                    "no manifest; not a model file written by azgym"),
    "manifest-not-json": (lambda path: model_file(path, manifest=npy(np.array("{format: 1"))),
                          "the manifest is not valid JSON"),
    "manifest-nan": (lambda path: model_file(
        path, manifest=npy(np.array('{"format": NaN}'))), "NaN is not a JSON number"),
    "manifest-not-string": (lambda path: model_file(path, manifest=npy(np.zeros(3))),
                            r"the manifest must be one string, got float64 of shape \(3,\)"),
    "manifest-a-list": (lambda path: model_file(path, manifest=[1, 2]),
                        "the manifest must be a JSON object, got list"),
    "manifest-without-training": (
        lambda path: model_file(path, manifest={k: v for k, v in sound_manifest().items()
                                                if k != "training"}),
        "manifest field 'training' must be a JSON object, got nothing"),
    "format-a-string": (lambda path: model_file(path, manifest=sound_manifest(format="1")),
                        "manifest field 'format' must be a JSON integer, got '1'"),
    "format-zero": (lambda path: model_file(path, manifest=sound_manifest(format=0)),
                    "manifest field 'format' must be >= 1, got 0"),
    "newer-format": (lambda path: model_file(path, manifest={"format": FORMAT + 1}),
                     rf"written in model-file format {FORMAT + 1}, newer than this azgym reads "
                     rf"\({FORMAT}\); upgrade azgym"),
    "other-model": (lambda path: model_file(path, manifest=sound_manifest(model="learned")),
                    "holds a 'learned' model, not 'ng-ransac'"),
    "other-feature-layout": (
        lambda path: model_file(path, manifest=sound_manifest(feature_layout="old-features-0")),
        "trained on feature layout 'old-features-0', but this azgym computes "
        "'test-features-1'; retrain the model"),
    "other-architecture-kind": (
        lambda path: model_file(path, manifest=sound_manifest(architecture={"kind": "mlp"})),
        "architecture kind 'mlp' is not one this azgym knows"),
    "architecture-size-bogus": (
        lambda path: model_file(path, manifest=sound_manifest(
            architecture={**ARCHITECTURE, "hidden": -3})),
        r"architecture hidden must be an integer in \[1, 1024\], got -3"),
    "architecture-disagrees": (
        lambda path: model_file(path, manifest=sound_manifest(
            architecture={**ARCHITECTURE, "hidden": 8})),
        r"array 'W1' has shape \(5, 4\), but the architecture .* needs \(5, 8\)"),
    "wrong-shape": (lambda path: model_file(path, arrays=with_array("W2", np.zeros((4, 4)))),
                    r"array 'W2' has shape \(4, 4\), but the architecture"),
    "missing-arrays": (lambda path: model_file(path, arrays=without("W2", "b2")),
                       "missing arrays: W2, b2"),
    "extra-array": (lambda path: model_file(path, arrays=with_array("W4", np.zeros(2))),
                    "arrays the architecture has no use for: W4"),
    "nan-weight": (lambda path: model_file(path, arrays=with_array(
        "b2", np.array([0.0, np.nan, 0.0, 0.0]))), r"array 'b2' holds non-finite values"),
    "inf-weight": (lambda path: model_file(path, arrays=with_array(
        "b3", np.array([np.inf]))), r"array 'b3' holds non-finite values"),
    "text-weight": (lambda path: model_file(path, arrays=with_array("b3", np.array(["1"]))),
                    "array 'b3' holds <U1 values, not numbers"),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_each_hostile_model_file_is_refused_with_its_message(tmp_path, case):
    build, message = HOSTILE[case]
    path = build(tmp_path / f"{case}.npz")
    with pytest.raises(ModelFileError, match=message) as caught:
        load_weights(path, "ng-ransac", feature_layout=LAYOUT)
    assert str(caught.value).startswith(f"{path}: ")  # names the file
    assert isinstance(caught.value, InvalidInputError)


def test_a_pickled_weight_is_refused_without_running_its_code(tmp_path):
    marker = tmp_path / "pwned"
    path = pickled(marker)(tmp_path / "pickled.npz")
    assert not marker.exists()
    with pytest.raises(ModelFileError, match="member 'W1.npy' holds object values, not numbers"):
        load_weights(path, "ng-ransac", feature_layout=LAYOUT)
    assert not marker.exists()
    np.load(path, allow_pickle=True)["W1"]  # what the refusal protects from
    assert marker.exists()


def test_a_sound_file_loads_back_as_written(tmp_path):
    from azgym._version import __version__

    path = sound(tmp_path / "model.npz")
    arrays, manifest = load_weights(path, "ng-ransac", feature_layout=LAYOUT)
    assert arrays.keys() == sound_arrays().keys()
    for name, value in sound_arrays().items():
        np.testing.assert_array_equal(arrays[name], value)
        assert arrays[name].dtype == np.float64
    assert manifest == sound_manifest(azgym_version=__version__)


def test_float32_and_big_endian_weights_load_as_float64(tmp_path):
    arrays = {name: value.astype(">f4") for name, value in sound_arrays().items()}
    path = model_file(tmp_path / "model.npz", arrays=arrays)
    loaded, _ = load_weights(path, "ng-ransac", feature_layout=LAYOUT)
    np.testing.assert_array_equal(loaded["W1"], arrays["W1"].astype(np.float64))
    assert loaded["W1"].dtype == np.float64


def test_the_running_feature_layout_is_the_default(tmp_path, monkeypatch):
    import sys
    import types

    features = types.ModuleType("azgym.localize.learned.features")
    features.FEATURE_LAYOUT = "running-layout-7"
    monkeypatch.setitem(sys.modules, "azgym.localize.learned.features", features)
    path = sound(tmp_path / "model.npz")
    with pytest.raises(ModelFileError, match="but this azgym computes 'running-layout-7'"):
        load_weights(path, "ng-ransac")


@pytest.mark.parametrize(("arrays", "training", "message"), [
    (without("b3"), {}, "missing arrays: b3"),
    (with_array("W1", np.full((5, 4), np.nan)), {}, "array 'W1' holds non-finite values"),
    (sound_arrays(), {"auc": float("nan")}, "the manifest is not plain JSON"),
    (sound_arrays(), {"when": object()}, "the manifest is not plain JSON"),
])
def test_save_refuses_what_load_would_refuse(tmp_path, arrays, training, message):
    path = tmp_path / "model.npz"
    with pytest.raises(ModelFileError, match=re.escape(message)):
        save_weights(path, "ng-ransac", arrays,
                     {"architecture": ARCHITECTURE, "feature_layout": LAYOUT,
                      "training": training})
    assert not path.exists()
