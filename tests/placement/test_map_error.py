"""The surveyed map's bias floor: the propagation by hand, and a Monte Carlo over drawn maps."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from azgym import cli
from azgym.localize import _kernels as K
from azgym.localize.refinement import refine_with_covariance
from azgym.placement.information import (
    contributions,
    map_contributions,
    map_sigma,
    map_variance,
    position_sigma,
)
from azgym.site.error_model import ErrorModel

WIDTH = 0.03


def floors(point, beacons, covariance, model):
    """(σ_pos, σ_map) at one point seeing every beacon."""
    points = np.array([point], dtype=float)
    seen = np.ones((1, len(beacons)), dtype=bool)
    width = np.full(len(beacons), WIDTH)
    info = contributions(points, beacons, width, model, seen).sum(axis=1)
    extra = map_contributions(points, beacons, width, covariance, model, seen).sum(axis=1)
    count = seen.sum(axis=1)
    return float(position_sigma(info, count)[0]), float(map_sigma(info, extra, count)[0])


def test_only_the_error_across_the_line_of_sight_moves_the_azimuth():
    # Beacon 4 m east: an error along x (the line of sight) changes nothing, one along y of
    # variance syy turns the azimuth by δy / 4, variance syy / 16.
    cov = np.array([[[0.01, 0.0], [0.0, 0.04]]])
    got = map_variance(np.zeros((1, 2)), np.array([[4.0, 0.0]]), cov)
    assert got[0, 0] == pytest.approx(0.04 / 16, rel=1e-12)
    # Beacon 2 m north: only sxx counts, over 2².
    got = map_variance(np.zeros((1, 2)), np.array([[0.0, 2.0]]), cov)
    assert got[0, 0] == pytest.approx(0.01 / 4, rel=1e-12)
    # Along the diagonal (1, 1)/√2 at 2 m: u⊥ = (−1, 1)/√2, u⊥ᵀΣu⊥ = (sxx − 2 sxy + syy) / 2.
    cov = np.array([[[0.01, 0.003], [0.003, 0.02]]])
    got = map_variance(np.zeros((1, 2)), np.array([[math.sqrt(2), math.sqrt(2)]]), cov)
    assert got[0, 0] == pytest.approx((0.01 - 0.006 + 0.02) / 2 / 4, rel=1e-12)


@pytest.mark.parametrize("count", [4, 6])
def test_beacons_evenly_round_with_a_round_error_give_its_closed_form(count):
    # Every beacon at R with Σ_b = s_b² I: m² = s_b²/R² for each, so M = (m²/σ²) I and
    # C M C = (m²/σ²) C: σ_map = (m/σ) σ_pos = (s_b/(R σ)) · σ R sqrt(4/n) = s_b sqrt(4/n).
    radius, s_b = 6.0, 0.02
    angles = 0.4 + 2 * math.pi * np.arange(count) / count
    beacons = radius * np.c_[np.cos(angles), np.sin(angles)]
    cov = np.broadcast_to(s_b ** 2 * np.eye(2), (count, 2, 2))
    _, got = floors((0.0, 0.0), beacons, cov, ErrorModel())
    assert got == pytest.approx(s_b * math.sqrt(4 / count), rel=1e-9)


def test_no_fix_means_no_floor_and_an_exact_map_none():
    model = ErrorModel()
    beacons = np.array([[5.0, 0.0], [0.0, 5.0], [-5.0, 1.0]])
    zero = np.zeros((3, 2, 2))
    assert floors((0.0, 0.0), beacons, zero, model)[1] == 0.0
    assert floors((0.0, 0.0), beacons[:2], zero[:2], model)[1] == math.inf


def _fix(beacons, azimuth, pose, model):
    start = np.array([pose[0], pose[1], math.cos(pose[2]), math.sin(pose[2])])
    out, cov = np.empty(K.REFINED_SIZE), np.empty((3, 3))
    n = len(beacons)
    refine_with_covariance(beacons[:, 0].copy(), beacons[:, 1].copy(), np.cos(azimuth),
                           np.sin(azimuth), np.full(n, WIDTH), np.ones(n, dtype=bool), True,
                           model.delta_alpha_d, model.coverage, start, 20, out, cov)
    return np.array([out[K.POSE_X], out[K.POSE_Y]])


def test_monte_carlo_over_maps_drawn_from_their_covariances_matches_the_prediction():
    # 400 maps drawn from the beacons' covariances, the localizer (model-weighted refinement)
    # given the drawn map: without frame noise its error is the bias, whose RMS is σ_map;
    # with one noisy frame per map, the RMS is σ_total = sqrt(σ_pos² + σ_map²). Sampling error
    # of an RMS of 400 draws: about 3.5 %.
    rng = np.random.default_rng(7)
    model = ErrorModel()
    truth = np.array([[11.0, -7.3], [11.0, 0.0], [7.3, 11.0], [-11.0, 3.0], [-4.0, -11.0]])
    root = rng.normal(0.0, 0.03, size=(5, 2, 2))
    cov = root @ np.swapaxes(root, 1, 2)  # five different, elongated covariances
    pose = (2.0, -1.5, 0.7)
    sigma, floor = floors(pose[:2], truth, cov, model)
    assert 0.3 * sigma < floor < 3 * sigma  # both matter: the check sees each
    exact = np.arctan2(truth[:, 1] - pose[1], truth[:, 0] - pose[0]) - pose[2]
    drawn = truth + np.einsum("bij,nbj->nbi", np.linalg.cholesky(cov),
                              rng.standard_normal((400, 5, 2)))
    noise = model.sample(np.hypot(*(truth - pose[:2]).T)[None].repeat(400, 0),
                         np.full(5, WIDTH), rng)
    bias = np.array([_fix(m, exact, pose, model) for m in drawn]) - pose[:2]
    total = np.array([_fix(m, exact + e, pose, model) for m, e in zip(drawn, noise,
                                                                      strict=True)]) - pose[:2]
    assert math.sqrt(np.mean(np.sum(bias ** 2, axis=1))) == pytest.approx(floor, rel=0.10)
    assert math.sqrt(np.mean(np.sum(total ** 2, axis=1))) == pytest.approx(
        math.hypot(sigma, floor), rel=0.10)


def test_analyze_with_a_survey_reports_the_map_share(tmp_path, capsys):
    from azgym.site import load_scenario

    beacons = load_scenario("paper-room").beacons
    rows = ["id,x,y,sxx,sxy,syy,observable,anchor,moved,rays,outliers,reason"]
    for beacon, (x, y) in zip(beacons.ids.tolist(), beacons.xy.tolist(), strict=True):
        if beacon == 12:
            rows.append(f'{beacon},,,,,,0,0,0,3,0,"narrow baseline"')
        else:
            rows.append(f'{beacon},{x},{y},0.0004,0,0.0004,1,0,0,40,0,""')
    (tmp_path / "survey.csv").write_text("\n".join(rows) + "\n")
    out = tmp_path / "analysis"
    assert cli.main(["layout", "analyze", "paper-room", "--step", "3", "--frames", "0",
                     "--survey", str(tmp_path), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "1 beacon absent (unobservable or not detected): 12" in printed
    assert "map's bias floor σ_map: median" in printed
    assert "the map's share of σ_total²: median" in printed
    result = json.loads((out / "layout.json").read_text())
    assert result["beacons"] == 11 and result["survey"]["absent_ids"] == [12]
    floor, total = result["survey"]["map_bias_floor"], result["survey"]["total"]
    assert 0 < floor["sigma_median_m"] < total["sigma_median_m"]
    assert total["sigma_median_m"] > result["predicted"]["sigma_median_m"]
    grids = np.load(out / "layout.npz")
    assert {"map_sigma", "total_sigma"} <= set(grids.files)
    assert (out / "layout.png").stat().st_size > 0
