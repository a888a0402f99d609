"""A site drawn with matplotlib: beacons with their ids, racks, walls, named routes, starts."""

from __future__ import annotations

import importlib.util

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from azgym.site import drawing, load_scenario  # noqa: E402


def test_a_scenario_is_drawn_with_its_beacon_ids_routes_and_starts():
    scenario = load_scenario("warehouse-small")
    figure = drawing.scenario_figure(scenario)
    try:
        axes = figure.axes[0]
        texts = {text.get_text() for text in axes.texts}
        assert {str(int(i)) for i in scenario.beacons.ids} <= texts  # every beacon's id
        legend = {text.get_text() for text in axes.get_legend().get_texts()}
        assert {f"route {route.name}" for route in scenario.routes} <= legend
        assert {"beacons", "racks", "walls", "starts"} <= legend
        assert scenario.name in axes.get_title()
    finally:
        plt.close(figure)


def test_the_note_names_the_skipped_figures_and_how_to_get_them(monkeypatch):
    assert drawing.figures_skipped(["cdf.png"]) is None  # matplotlib is installed here
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *rest: None if name == "matplotlib" else real(name, *rest))
    note = drawing.figures_skipped(["cdf.png", "causes.png"])
    assert note is not None and "cdf.png, causes.png" in note
    assert 'pip install "azgym[plot]"' in note
