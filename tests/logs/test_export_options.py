"""azgym export route refusing a rate, seed or name out of range, by name, before any work."""

from __future__ import annotations

import re

import pytest

from azgym.cli import main

RATE = r"motion_rate_hz must be > 0 Hz, got "
NOT_FINITE = r"motion_rate_hz must be a finite number \[Hz\], got "
SEED = r"seed must be an integer in \[0, 2147483648\), got "
NAME = r"name: must be a plain file name \(.*at most 64 characters\), got "


@pytest.mark.parametrize(("options", "message"), [
    (["--motion-rate", "0"], RATE + "0.0"),
    (["--motion-rate", "-5"], RATE + "-5.0"),
    (["--motion-rate", "nan"], NOT_FINITE + "nan"),
    (["--motion-rate", "inf"], NOT_FINITE + "inf"),
    (["--seed", "-1"], SEED + "-1"),
    (["--seed", str(2**31)], SEED + str(2**31)),
    (["--name", "../outside"], NAME + "'../outside'"),
    (["--name=-hidden"], NAME + "'-hidden'"),
    (["--name", "x" * 65], NAME),
], ids=["rate-0", "rate-negative", "rate-nan", "rate-inf", "seed-negative", "seed-2**31",
        "name-separator", "name-option", "name-65"])
def test_export_route_refuses_an_option_out_of_range(tmp_path, capsys, options, message):
    out = tmp_path / "log"
    assert main(["export", "route", "--scenario", "warehouse-small", "--out", str(out),
                 *options]) == 2
    assert re.search(f"azgym: error: {message}", capsys.readouterr().err)
    assert not out.exists()
