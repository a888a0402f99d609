"""The weight file of a learned model: an .npz archive of float arrays and a JSON manifest.

A model file is a zip archive written by :func:`save_weights`: one ``.npy`` member per weight
array and a ``manifest`` member, a 0-d string array holding JSON::

    {"format": 1, "model": "ng-ransac", "azgym_version": "0.2.0",
     "architecture": {"kind": "deepsets-context-1", "inputs": 8, "hidden": 32},
     "feature_layout": "measurement-features-1", "training": {...}}

Anyone can hand azgym such a file, so :func:`load_weights` reads it without pickle (an object
array would run code), reads each array's header before its data (a header claiming a huge
shape must not allocate it), bounds every size, and checks everything a served model relies
on before returning: the model name, the format, the features it was trained on, and every
array's presence, shape and finiteness. Each problem is a :class:`ModelFileError` naming the
file and what is wrong.

The file itself is read as every file azgym did not write (:mod:`azgym.untrusted`): a regular
file (not a device, FIFO, socket or folder, which could read without end or wait for ever),
opened without blocking and read up to :data:`MAX_FILE_BYTES`; its members are inflated in
chunks up to a cap whatever their headers declare.
"""

from __future__ import annotations

import io
import json
import math
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from azgym.errors import InvalidInputError, ModelFileError
from azgym.untrusted import open_archive, read_member, read_regular_file

__all__ = ["FORMAT", "MAX_FILE_BYTES", "MODELS", "ModelFileError", "array_shapes",
           "load_weights", "model_path", "save_weights"]

MODELS = Path(__file__).resolve().parent / "models"
"""The folder of the weight files that ship with azgym (``<model>.npz``, model cards beside)."""
FORMAT = 1
"""The model-file format this azgym writes and the newest it reads."""
MAX_FILE_BYTES = 16 * 2**20
"""A model file larger than this is refused (an inlier scorer's is about 20 kB)."""
MAX_ARRAY_BYTES = 8 * 2**20
"""An array (or the manifest) larger than this is refused, whatever its header claims."""
MAX_MEMBERS = 64
"""A model file with more members than this is refused."""
MANIFEST = "manifest"
"""The name of the manifest's member (``manifest.npy`` in the archive)."""
FIELDS = {"format": int, "model": str, "azgym_version": str, "architecture": dict,
          "feature_layout": str, "training": dict}
"""Every field of a manifest and its JSON type."""
ZIP_MAGIC = b"PK\x03\x04"
"""The first bytes of a zip archive (its first member's header)."""
ARCHITECTURES = ("deepsets-context-1", "deepsets-regression-1")
"""The kinds of architecture this azgym serves (:func:`array_shapes`)."""


def array_shapes(architecture: dict[str, Any]) -> dict[str, tuple[int, ...]]:
    """The arrays an architecture consists of, and their shapes: the one rule for both.

    ``deepsets-context-1`` (the inlier scorer, :mod:`azgym.localize.learned.inlier_network`):
    ``W1`` (inputs, hidden), ``b1`` (hidden,), ``W2`` (3 hidden, hidden) acting on
    ``[h1, max h1, mean h1]``, ``b2`` (hidden,), ``w3`` (hidden,), ``b3`` (1,).

    ``deepsets-regression-1`` (the pose regressor, :mod:`azgym.localize.learned.pose_network`):
    the same six arrays (``w3``, ``b3`` give the trust logits), then the head: ``W4``
    (3 hidden, hidden) acting on the pooled ``[max h2, mean h2, trusted mean h2]``, ``b4``
    (hidden,), ``W5`` (hidden, hidden), ``b5`` (hidden,), ``W6`` (hidden, 4), ``b6`` (4,).

    Raises:
        ModelFileError: Another kind of architecture, or sizes that are not whole numbers in
            [1, 1024].
    """
    kind = architecture.get("kind")
    if kind not in ARCHITECTURES:
        raise ModelFileError(f"architecture kind {kind!r} is not one this azgym knows "
                             f"({', '.join(ARCHITECTURES)})")
    sizes = {}
    for key in ("inputs", "hidden"):
        value = architecture.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 1024:
            raise ModelFileError(f"architecture {key} must be an integer in [1, 1024], "
                                 f"got {value!r}")
        sizes[key] = value
    inputs, hidden = sizes["inputs"], sizes["hidden"]
    shapes = {"W1": (inputs, hidden), "b1": (hidden,), "W2": (3 * hidden, hidden),
              "b2": (hidden,), "w3": (hidden,), "b3": (1,)}
    if kind == "deepsets-regression-1":
        shapes.update({"W4": (3 * hidden, hidden), "b4": (hidden,), "W5": (hidden, hidden),
                       "b5": (hidden,), "W6": (hidden, 4), "b6": (4,)})
    return shapes


def model_path(owner: str, weights: Any, shipped: Path) -> Path:
    """The weight file a localizer's ``weights`` hyperparameter names.

    ``weights`` is a path, or None for the file shipped with azgym (``shipped``).

    Raises:
        InvalidInputError: ``weights`` is neither a path nor None.
    """
    if weights is None:
        return shipped
    if not isinstance(weights, str | Path):
        raise InvalidInputError(f"{owner}.weights must be a path to a weight file or None, "
                                f"got {weights!r}")
    return Path(weights)


def served(arrays: dict[str, np.ndarray], manifest: dict[str, Any], kind: str, what: str,
           order: tuple[str, ...]) -> tuple[dict[str, Any], np.ndarray]:
    """A network's architecture and weights, once the model file holds that network.

    Args:
        arrays: The weight arrays (:func:`load_weights`).
        manifest: The model file's manifest.
        kind: The architecture the serving network computes.
        what: The network's name, for the messages.
        order: The arrays' order in the packed vector the compiled forward pass reads.

    Returns:
        The architecture, and the weights flattened into one read-only float64 vector.

    Raises:
        ModelFileError: Another kind of architecture, or an array of another shape.
    """
    architecture = manifest["architecture"]
    if architecture.get("kind") != kind:
        raise ModelFileError(f"architecture kind {architecture.get('kind')!r}: the {what} "
                             f"computes {kind!r}")
    for name, shape in array_shapes(architecture).items():
        if np.shape(arrays[name]) != shape:
            raise ModelFileError(f"array {name!r} has shape {np.shape(arrays[name])}, the "
                                 f"architecture needs {shape}")
    params = np.concatenate([np.asarray(arrays[name], dtype=np.float64).ravel()
                             for name in order])
    params.flags.writeable = False
    return architecture, params


def save_weights(path: Path | str, model: str, arrays: dict[str, np.ndarray],
                 manifest: dict[str, Any]) -> Path:
    """Write a model file, atomically; it is checked as :func:`load_weights` checks it.

    Args:
        path: The file to write (``.npz``).
        model: The model's name, e.g. ``"ng-ransac"``.
        arrays: The weights, named and shaped as ``array_shapes(manifest["architecture"])``.
        manifest: ``architecture``, ``feature_layout`` and ``training`` (JSON values);
            ``format``, ``model`` and ``azgym_version`` are filled in.

    Raises:
        ModelFileError: The arrays or the manifest are not what a model file holds.
    """
    from azgym._version import __version__
    from azgym.files import write_file

    path = Path(path)
    full = {**manifest, "format": FORMAT, "model": model, "azgym_version": __version__}
    try:
        text = json.dumps(full, allow_nan=False, sort_keys=True)
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"{path}: the manifest is not plain JSON: {exc}") from None
    written = _check_fields(path, json.loads(text))
    checked = _checked(path, model, written, arrays, written["feature_layout"])
    buffer = io.BytesIO()
    np.savez(buffer, allow_pickle=False, **checked, **{MANIFEST: np.array(text)})
    return write_file(path, buffer.getvalue())


def load_weights(path: Path | str, model: str, *, feature_layout: str | None = None
                 ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Read and check a model file; nothing is used before all of it is checked.

    Args:
        path: The model file.
        model: The model it must hold, e.g. ``"ng-ransac"``.
        feature_layout: The feature layout it must have been trained on (default: the running
            azgym's, :data:`azgym.localize.learned.features.FEATURE_LAYOUT`).

    Returns:
        The weight arrays (float64, as the architecture shapes them) and the manifest.

    Raises:
        ModelFileError: The file is missing, not a model file, damaged, or made for another
            model, architecture, feature layout or a newer azgym.
    """
    if feature_layout is None:
        from azgym.localize.learned.features import FEATURE_LAYOUT

        feature_layout = FEATURE_LAYOUT
    path = Path(path)
    members = _read_members(path)
    if MANIFEST not in members:
        raise ModelFileError(f"{path}: no manifest; not a model file written by azgym")
    manifest = _parse_manifest(path, members.pop(MANIFEST))
    return _checked(path, model, manifest, members, feature_layout), manifest


def _read_members(path: Path) -> dict[str, np.ndarray]:
    """Every ``.npy`` member of the archive, read without pickle and within the size bounds."""
    data = read_regular_file(path, MAX_FILE_BYTES, "model file", ModelFileError)
    if not zipfile.is_zipfile(io.BytesIO(data)):
        if data.startswith(ZIP_MAGIC):
            raise ModelFileError(f"{path}: truncated (a zip archive without its end)")
        raise ModelFileError(f"{path}: not a model file (not an .npz zip archive)")
    try:
        with open_archive(path, data, "model file", ModelFileError) as archive:
            infos = archive.infolist()
            if len(infos) > MAX_MEMBERS:
                raise ModelFileError(f"{path}: {len(infos)} members, more than a model file "
                                     f"has ({MAX_MEMBERS})")
            names = [_member_name(path, info) for info in infos]
            if len(set(names)) != len(names):
                raise ModelFileError(f"{path}: a member is listed twice in the archive")
            return {name: _read_array(path, archive, info)
                    for name, info in zip(names, infos, strict=True)}
    except (zipfile.BadZipFile, EOFError, zlib.error, NotImplementedError) as exc:
        raise ModelFileError(f"{path}: damaged archive: {exc}") from None


def _member_name(path: Path, info: zipfile.ZipInfo) -> str:
    """A member's array name: its file name without ``.npy``."""
    if not info.filename.endswith(".npy") or info.filename == ".npy":
        raise ModelFileError(f"{path}: member {info.filename!r} is not an .npy array")
    return info.filename[:-len(".npy")]


def _read_array(path: Path, archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> np.ndarray:
    """One member as an array: its header checked before its data is used."""
    name = info.filename
    stream = io.BytesIO(read_member(path, archive, info, MAX_ARRAY_BYTES + 4096, "model file",
                                       ModelFileError))
    try:
        version = np.lib.format.read_magic(stream)
        reader = {(1, 0): np.lib.format.read_array_header_1_0,
                  (2, 0): np.lib.format.read_array_header_2_0}.get(version)
        if reader is None:
            raise ValueError(f"unsupported .npy version {version}")
        shape, fortran, dtype = reader(stream)
    except ValueError as exc:
        raise ModelFileError(f"{path}: member {name!r} is not a valid .npy array: {exc}"
                             ) from None
    if dtype.kind not in "fiuU" or dtype.hasobject:
        raise ModelFileError(f"{path}: member {name!r} holds {dtype} values, not numbers")
    nbytes = math.prod(shape) * dtype.itemsize
    if nbytes > MAX_ARRAY_BYTES:
        raise ModelFileError(f"{path}: member {name!r} claims shape {shape}, larger than "
                             f"{MAX_ARRAY_BYTES // 2**20} MiB")
    data = stream.read(nbytes + 1)
    if len(data) != nbytes:
        raise ModelFileError(f"{path}: member {name!r} holds {len(data)} bytes of data, its "
                             f"header says {nbytes}")
    return np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")


def _parse_manifest(path: Path, stored: np.ndarray) -> dict[str, Any]:
    """The manifest member's JSON, checked by :func:`_check_fields`."""
    if stored.dtype.kind != "U" or stored.shape != ():
        raise ModelFileError(f"{path}: the manifest must be one string, got {stored.dtype} "
                             f"of shape {stored.shape}")
    try:
        manifest = json.loads(str(stored), parse_constant=_refuse_constant)
    except (ValueError, RecursionError) as exc:
        raise ModelFileError(f"{path}: the manifest is not valid JSON: {exc}") from None
    return _check_fields(path, manifest)


def _check_fields(path: Path, manifest: Any) -> dict[str, Any]:
    """The manifest, once it is an object with every field, in a format this azgym reads."""
    if not isinstance(manifest, dict):
        raise ModelFileError(f"{path}: the manifest must be a JSON object, got "
                             f"{type(manifest).__name__}")
    version = manifest.get("format")
    if isinstance(version, int) and not isinstance(version, bool) and version > FORMAT:
        raise ModelFileError(f"{path}: written in model-file format {version}, newer than this "
                             f"azgym reads ({FORMAT}); upgrade azgym")
    for field, kind in FIELDS.items():
        value = manifest.get(field)
        if not isinstance(value, kind) or isinstance(value, bool):
            got = "nothing" if field not in manifest else repr(value)[:60]
            raise ModelFileError(f"{path}: manifest field {field!r} must be a JSON "
                                 f"{_JSON_NAMES[kind]}, got {got}")
    if manifest["format"] < 1:
        raise ModelFileError(f"{path}: manifest field 'format' must be >= 1, "
                             f"got {manifest['format']}")
    return manifest


_JSON_NAMES = {int: "integer", str: "string", dict: "object"}


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def _checked(path: Path, model: str, manifest: dict[str, Any], arrays: dict[str, Any],
             feature_layout: str) -> dict[str, np.ndarray]:
    """The arrays as float64, once the model, feature layout and every array are right."""
    if manifest["model"] != model:
        raise ModelFileError(f"{path}: holds a {manifest['model']!r} model, not {model!r}")
    if manifest["feature_layout"] != feature_layout:
        raise ModelFileError(f"{path}: trained on feature layout {manifest['feature_layout']!r}, "
                             f"but this azgym computes {feature_layout!r}; retrain the model")
    try:
        shapes = array_shapes(manifest["architecture"])
    except ModelFileError as exc:
        raise ModelFileError(f"{path}: {exc}") from None
    missing = sorted(set(shapes) - set(arrays))
    if missing:
        raise ModelFileError(f"{path}: missing arrays: {', '.join(missing)}")
    extra = sorted(set(arrays) - set(shapes))
    if extra:
        raise ModelFileError(f"{path}: arrays the architecture has no use for: "
                             f"{', '.join(extra)}")
    checked = {}
    for name, shape in shapes.items():
        array = np.asarray(arrays[name])
        if array.dtype.kind not in "fiu":
            raise ModelFileError(f"{path}: array {name!r} holds {array.dtype} values, "
                                 "not numbers")
        if array.shape != shape:
            raise ModelFileError(f"{path}: array {name!r} has shape {array.shape}, but the "
                                 f"architecture {manifest['architecture']} needs {shape}")
        checked[name] = np.ascontiguousarray(array, dtype=np.float64)
        if not np.isfinite(checked[name]).all():
            raise ModelFileError(f"{path}: array {name!r} holds non-finite values (NaN or inf)")
    return checked
