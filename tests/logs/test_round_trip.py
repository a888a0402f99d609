"""A simulated route written as a log scores exactly as the route itself, and the shipped log."""

from __future__ import annotations

import dataclasses
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from azgym.bench.report.results import cases_digest
from azgym.bench.run.contenders import Contender
from azgym.bench.run.runner import run_contenders
from azgym.bench.suites.base import route_cases
from azgym.bench.suites.data import log_cases
from azgym.cli import main
from azgym.logs import export_route, read_log
from azgym.logs.manifest import FORMAT_VERSION
from azgym.logs.read import shipped_logs
from azgym.profile import SECTIONS
from azgym.sensing.motion import ImuModel, OdometryModel
from azgym.world.drive import simulate

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "envs" / "logs" / "warehouse-small-simulated"


def _simulated(scenario: str, route: str, seed: int, rate: float):
    frames = simulate(scenario, route, seed, odometry=OdometryModel(rate_hz=rate),
                      imu=ImuModel(rate_hz=rate))
    return route_cases(scenario, f"{scenario}/{route}", frames)


def _same_case(a, b) -> None:
    assert (a.scenario, a.group, a.sequence, a.cause, a.pose, a.initial, a.time, a.event) == \
        (b.scenario, b.group, b.sequence, b.cause, b.pose, b.initial, b.time, b.event)
    assert a.frame == b.frame or None in (a.frame, b.frame)  # a route's frames have no number
    for field in ("ids", "azimuth", "quality"):
        x, y = getattr(a.measurements, field), getattr(b.measurements, field)
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y)
    assert a.motion.time == b.motion.time
    for part in ("odometry", "imu"):
        for field in dataclasses.fields(getattr(a.motion, part)):
            x = getattr(getattr(a.motion, part), field.name)
            y = getattr(getattr(b.motion, part), field.name)
            assert x.shape == y.shape and np.array_equal(x, y, equal_nan=True)


@pytest.mark.slow
def test_an_exported_route_reads_back_as_the_same_cases_bit_for_bit(tmp_path):
    export_route("warehouse-small", "cross-aisle", 5, tmp_path / "log", motion_rate_hz=25.0)
    cases = log_cases(read_log(tmp_path / "log"))
    simulated = _simulated("warehouse-small", "cross-aisle", 5, 25.0)
    assert len(cases) == len(simulated) > 100
    for a, b in zip(cases, simulated, strict=True):
        _same_case(a, b)
    assert cases_digest(cases) == cases_digest(simulated)


@pytest.mark.slow
def test_the_log_gives_the_very_errors_of_the_route_through_the_runner():
    cases = log_cases(read_log(SHIPPED))
    simulated = _simulated("warehouse-small", "pick-and-back", 0, 20.0)
    contenders = [Contender("ransac", "ransac"), Contender("gated-ekf", "gated-ekf")]
    logged = run_contenders(cases, contenders, workers=1)
    direct = run_contenders(simulated, contenders, workers=1)
    for label in ("ransac", "gated-ekf"):
        a, b = logged[label], direct[label]
        assert np.array_equal(a.ok, b.ok) and a.ok.any()
        assert np.array_equal(a.position, b.position, equal_nan=True)
        assert np.array_equal(a.heading, b.heading, equal_nan=True)


@pytest.mark.slow
def test_the_shipped_log_is_what_export_writes_in_any_format(tmp_path):
    # The shipped log may be of an older format (1): its tables are export's to the byte, its
    # manifest is but for the format and the profile sections, and it reads as the same cases.
    export_route("warehouse-small", "pick-and-back", 0, tmp_path / "log",
                 name="warehouse-small-simulated", motion_rate_hz=20.0)
    for path in SHIPPED.iterdir():
        if path.name != "log.toml":
            assert (tmp_path / "log" / path.name).read_bytes() == path.read_bytes(), path.name
    shipped, written = (tomllib.loads((folder / "log.toml").read_text())
                        for folder in (SHIPPED, tmp_path / "log"))
    assert written["format"] == FORMAT_VERSION == 2
    assert {k: v for k, v in written.items() if k not in ("format", *SECTIONS)} == \
        {k: v for k, v in shipped.items() if k not in ("format", *SECTIONS)}
    for a, b in zip(log_cases(read_log(SHIPPED)), log_cases(read_log(tmp_path / "log")),
                    strict=True):
        _same_case(a, b)


def test_the_shipped_log_is_small_labelled_simulated_and_installed():
    manifest = tomllib.loads((SHIPPED / "log.toml").read_text())
    assert manifest["simulated"] is True and "SIMULATED" in manifest["description"]
    assert sum(p.stat().st_size for p in SHIPPED.iterdir()) < 200_000
    assert shipped_logs()["warehouse-small-simulated"].resolve() == SHIPPED.resolve()
    log = read_log("warehouse-small-simulated")  # by name
    assert 200 <= len(log.frames["time"]) and log.has_truth and log.imu is not None
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["azgym.site.scenarios"]
    shipped = {p.relative_to(ROOT / "envs").as_posix() for p in SHIPPED.iterdir()}
    assert shipped == {p.relative_to(ROOT / "envs").as_posix() for g in globs
                       for p in (ROOT / "envs").glob(g) if p.parent == SHIPPED}


@pytest.mark.slow
def test_bench_data_writes_a_suites_results_for_the_dataset(tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["bench", "--data", str(SHIPPED), "--localizer", "ransac", "--workers", "1",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "results.json").read_text())
    assert summary["suite"] == "data:warehouse-small-simulated" and summary["split"] == "data"
    assert summary["dataset"]["sha256"] == read_log(SHIPPED).sha256
    assert summary["dataset"]["simulated"] is True
    assert summary["localizers"]["ransac"]["tracking"] is not None
    assert (out / "frames.csv").read_text().count("\n") == summary["n_frames"] + 1
    assert "data:warehouse-small-simulated" in capsys.readouterr().out
