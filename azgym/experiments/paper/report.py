"""Write the reproduction's results: ``results.json``, a Markdown table, figures like Fig. 4-7."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from azgym.errors import require
from azgym.experiments.paper.reproduce import (
    ACCEPTANCE_RANSAC_CM,
    PAPER_MEAN_ERROR_CM,
    PAPER_RUNTIME_US,
    Reproduction,
)

__all__ = ["PAPER_FILES", "markdown_table", "paper_method", "write_outputs"]

_RESULTS, _TABLE, _RUNS = "results.json", "results.md", "runs.npz"
_ERROR_MAP, _ERROR_CDF = "error_map_k{k}.png", "error_cdf.png"
PAPER_FILES = (_RESULTS, _TABLE, _RUNS, _ERROR_MAP.format(k="*"), _ERROR_CDF)
"""What :func:`write_outputs` writes into its folder (glob patterns): what ``azgym reproduce
paper`` claims in ``--out``."""


def _fmt(value: float | None, digits: int = 2) -> str:
    return "–" if value is None or (isinstance(value, float) and math.isnan(value)) else \
        f"{value:.{digits}f}"


def markdown_table(results: dict[str, Any]) -> str:
    """The results as Markdown: one table per outlier count, the paper's figures beside ours."""
    protocol = results["protocol"]
    lines = [
        "# Rátosi & Simon (2021), Sec. 3 — reproduced by azgym",
        "",
        f"Scenario `{results['scenario']}`; grid step {protocol['grid_step']} m, "
        f"{protocol['realisations']} realisations per point, seed {protocol['seed']}. "
        "Position errors in cm, heading errors in degrees. *all*: every grid point; "
        "*far*: grid points within 0.5 m of a beacon left out. Failure: no estimate, or error "
        "> 1 m. Limit: mean error of optimally weighted least squares on the correctly "
        "measured beacons (see `azgym/experiments/paper/bound.py`); *× limit* is mean / limit "
        "(far).",
        "",
    ]
    if "mex_exhaustive_ms" in results:
        lines += [f"Exhaustive 1 cm MEX over the room: {results['mex_exhaustive_ms']:.0f} ms per "
                  f"estimate (paper: {PAPER_RUNTIME_US['mex'] / 1000:.0f} ms in Matlab); the "
                  "table's MEX runs coarse-to-fine, which returns the same grid point "
                  "(tests/localize/test_mex.py).", ""]
    for k in results["limit"]:
        limit = results["limit"][k]
        lines += [
            f"## K = {k} outlier{'s' if k != '1' else ''}",
            "",
            f"Weighted-LS limit: mean {limit['mean_cm_all']:.2f} cm (all), "
            f"{limit['mean_cm_far']:.2f} cm (far); RMS {limit['rms_cm_far']:.2f} cm (far).",
            "",
            "| localizer | paper mean | mean (all) | mean (far) | median | p75 | p95 | max "
            "| heading mean | failures | × limit | median µs |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        for label, entry in results["localizers"].items():
            row = entry["by_k"].get(k)
            if row is None:
                continue
            everything, far = row["all"], row["far"]
            method = paper_method(entry)
            paper = PAPER_MEAN_ERROR_CM.get(method or "") if k == "0" else None
            if paper is None and method == "ransac" and int(k) in ACCEPTANCE_RANSAC_CM:
                paper_text = f"(≤ {ACCEPTANCE_RANSAC_CM[int(k)]} target)"
            elif paper is None and method == "mex" and k != "0":
                paper_text = "no usable result"
            else:
                paper_text = _fmt(paper)
            ratio = far["mean_cm"] / limit["mean_cm_far"] if limit["mean_cm_far"] else math.nan
            lines.append(
                f"| {label} | {paper_text} | {_fmt(everything['mean_cm'])} | "
                f"{_fmt(far['mean_cm'])} | {_fmt(everything['median_cm'])} | "
                f"{_fmt(everything['p75_cm'])} | {_fmt(everything['p95_cm'])} | "
                f"{_fmt(everything['max_cm'], 1)} | {_fmt(everything['heading_mean_deg'], 3)} | "
                f"{100 * everything['failure_rate']:.2f} % | {_fmt(ratio)} | "
                f"{_fmt(row['median_us'], 1)} |"
            )
        lines.append("")
    return "\n".join(lines)


def paper_method(entry: dict[str, Any]) -> str | None:
    """Which of the paper's methods a contender is: "ransac", "mex" or None.

    The paper's RANSAC is ``ransac`` with its default hyperparameters; its MEX is ``mex`` with
    any step schedule (coarse-to-fine returns the exhaustive search's grid point).
    """
    if entry["spec"] == "ransac" and not entry["params"]:
        return "ransac"
    return "mex" if entry["spec"] == "mex" else None


def write_outputs(reproduction: Reproduction, out: Path, figures: bool = True) -> list[Path]:
    """Write results.json, results.md, runs.npz and (with matplotlib) the figures into ``out``."""
    results = reproduction.results
    out.mkdir(parents=True, exist_ok=True)
    written = [out / _RESULTS, out / _TABLE, out / _RUNS]
    written[0].write_text(json.dumps(results, indent=1, allow_nan=True) + "\n", encoding="utf-8")
    written[1].write_text(markdown_table(results) + "\n", encoding="utf-8")
    # Typed as Any: numpy's stub would take a key for savez's own allow_pickle flag.
    arrays: dict[str, Any] = {f"{label}__k{k}": errors
                              for label, by_k in reproduction.errors.items()
                              for k, errors in by_k.items()}
    np.savez_compressed(written[2], **arrays)
    if figures:
        written += _figures(reproduction, out)
    return written


def _figures(reproduction: Reproduction, out: Path) -> list[Path]:
    """error_map_k0.png and error_map_k1.png (RANSAC and MEX), then error_cdf.png (every K)."""
    require("matplotlib", "plot")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    per_point = reproduction.results["per_point"]
    methods = {paper_method(entry): label
               for label, entry in reproduction.results["localizers"].items()}
    labels = [methods[m] for m in ("ransac", "mex") if methods.get(m) in per_point]
    written = [_error_map(plt, per_point, labels, k, out / _ERROR_MAP.format(k=k))
               for k in ("0", "1") if labels and k in per_point[labels[0]]]
    written.append(_error_cdfs(plt, reproduction, out / _ERROR_CDF))
    return written


def _error_map(plt: Any, per_point: dict[str, Any], labels: list[str], k: str,
               path: Path) -> Path:
    """One panel per localizer: its mean position error at each grid point, with K outliers."""
    from matplotlib.colors import LogNorm

    fig, axes = plt.subplots(1, len(labels), figsize=(5.2 * len(labels), 4.4),
                             squeeze=False, constrained_layout=True)
    highest = max(float(np.nanmax(per_point[label][k]["mean_cm"])) for label in labels)
    # One colour scale for every panel; errors below 0.5 cm are shown as 0.5 cm.
    lowest = 0.5
    norm = LogNorm(vmin=lowest, vmax=max(10.0, highest))
    for ax, label in zip(axes[0], labels, strict=False):
        data = per_point[label][k]
        xs, ys = np.array(data["x"]), np.array(data["y"])
        grid_x, grid_y = np.unique(xs), np.unique(ys)
        image = np.full((grid_y.size, grid_x.size), np.nan)
        image[np.searchsorted(grid_y, ys), np.searchsorted(grid_x, xs)] = np.maximum(
            np.array(data["mean_cm"], dtype=float), lowest)
        shown = ax.pcolormesh(grid_x, grid_y, image, shading="nearest", cmap="viridis",
                              norm=norm)
        ax.set_title(f"{label}, K = {k}")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal")
    fig.colorbar(shown, ax=axes[0].tolist(), label="mean position error per point [cm]")
    return _save(fig, path, plt)


def _error_cdfs(plt: Any, reproduction: Reproduction, path: Path) -> Path:
    """One panel per outlier count K: each localizer's share of runs within each error."""
    ks = list(reproduction.results["limit"])
    fig, axes = plt.subplots(1, len(ks), figsize=(4.2 * len(ks), 3.8), squeeze=False,
                             constrained_layout=True, sharey=True)
    for ax, k in zip(axes[0], ks, strict=False):
        for label, by_k in reproduction.errors.items():
            if k not in by_k:
                continue
            errors = by_k[k]
            # A missing estimate is a failure: it sits at +inf, never at zero error.
            ranked = np.sort(np.where(np.isnan(errors), np.inf, errors))
            ax.step(ranked, np.arange(1, ranked.size + 1) / ranked.size, where="post",
                    label=label)
        ax.set_xscale("log")
        ax.set_xlim(left=0.05)  # MEX is exact (0 cm) where the truth lies on its 1 cm lattice
        ax.set_title(f"K = {k}")
        ax.set_xlabel("position error [cm]")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("share of runs")
    axes[0][-1].legend(loc="lower right", fontsize=8)
    return _save(fig, path, plt)


def _save(fig: Any, path: Path, plt: Any) -> Path:
    """Write the figure to ``path`` and close it (pyplot keeps open figures alive)."""
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
