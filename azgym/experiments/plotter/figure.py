"""The outputs of Plotter's reproduction: its figures, and each method's error distribution.

``results.json`` holds the figures; ``errors.png`` draws each method's cumulative error
distribution (Fig. 5(c)).
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

from azgym.experiments.plotter.reproduce import METHODS
from azgym.files import prepare_folder, write_file

__all__ = ["LABELS", "PLOTTER_FILES", "write_figure", "write_outputs"]

LABELS = {"tkf": "TKF", "lpkf": "LPKF", "naive": "naive accumulation"}
_RESULTS, _FIGURE = "results.json", "errors.png"
PLOTTER_FILES = (_RESULTS, _FIGURE)
"""What :func:`write_outputs` writes into its folder: what ``azgym reproduce plotter`` claims in
``--out``."""


def write_outputs(result: dict[str, Any], out: Path) -> list[Path]:
    """``results.json`` (the figures, without the pooled errors) and the figure, in ``out``."""
    prepare_folder(out)
    summary = {key: value for key, value in result.items() if key != "errors"}
    return [write_file(out / _RESULTS, json.dumps(summary, indent=1) + "\n"),
            write_figure(result, out / _FIGURE)]


def write_figure(result: dict[str, Any], path: str | Path) -> Path:
    """Draw the CDF of each method's position error, the paper's 2.6 cm mark beside; write a PNG.

    matplotlib is imported here, so the reproduction itself does not need it.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    figure, axes = plt.subplots(figsize=(6.0, 4.0))
    for method in METHODS:
        errors = np.sort(result["errors"][method])
        errors = errors[np.isfinite(errors)]
        share = np.arange(1, errors.size + 1) / max(len(result["errors"][method]), 1)
        axes.plot(errors * 100.0, share,
                  label=f"{LABELS[method]} (90 %: {result['p90'][method] * 100:.1f} cm)")
    axes.axvline(result["paper"]["lpkf_p90"] * 100.0, color="grey", linestyle=":",
                 label="paper: LPKF 90 % < 2.6 cm")
    axes.axhline(0.9, color="grey", linewidth=0.5)
    axes.set_xscale("log")
    axes.set_xlabel("position error [cm]")
    axes.set_ylabel("share of frames")
    axes.set_title(f"Plotter's square trail, {result['runs']} runs of {result['lap_s']:.0f} s")
    axes.legend(loc="lower right", fontsize=8)
    figure.tight_layout()
    image = io.BytesIO()
    figure.savefig(image, format="png", dpi=120)
    plt.close(figure)
    return write_file(Path(path), image.getvalue())
