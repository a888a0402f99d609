"""``azgym show``: a scenario drawn to a PNG, shipped or the user's, never over a file unasked."""

from __future__ import annotations

import importlib.util

from azgym.cli import main
from azgym.site.generator import write_generated

PNG = b"\x89PNG\r\n\x1a\n"


def test_show_draws_a_shipped_scenario_and_replaces_it_only_with_overwrite(tmp_path, capsys):
    out = tmp_path / "site.png"
    assert main(["show", "warehouse-small", "--out", str(out)]) == 0
    assert out.read_bytes().startswith(PNG)
    assert str(out) in capsys.readouterr().out
    out.write_bytes(b"mine")
    assert main(["show", "warehouse-small", "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err and out.read_bytes() == b"mine"
    assert main(["show", "warehouse-small", "--out", str(out), "--overwrite"]) == 0
    assert out.read_bytes().startswith(PNG)


def test_show_draws_a_generated_site_beside_its_file(tmp_path, monkeypatch):
    site = tmp_path / "mine.toml"
    write_generated(site, 7)
    monkeypatch.chdir(tmp_path)
    assert main(["show", str(site)]) == 0
    assert (tmp_path / "mine.png").read_bytes().startswith(PNG)


def test_show_without_matplotlib_names_the_extra(tmp_path, monkeypatch, capsys):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *rest: None if name == "matplotlib" else real(name, *rest))
    out = tmp_path / "site.png"
    assert main(["show", "warehouse-small", "--out", str(out)]) == 2
    assert 'pip install "azgym[plot]"' in capsys.readouterr().err and not out.exists()


def test_show_names_an_unknown_scenario(tmp_path, capsys):
    assert main(["show", "warehouse-smal", "--out", str(tmp_path / "x.png")]) == 2
    assert "warehouse-small" in capsys.readouterr().err
