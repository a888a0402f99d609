"""Each command's output names are one list, its writer's, and the command claims that list.

For every command that writes into ``--out`` (but ``bench`` on a suite or a log; ``bench
mapping`` is here): a small run writes exactly the names its writer exports (every file written
is one of them, every name is written), and the command, given a folder holding any one of those
files, refuses it by name without ``--overwrite``: no file a run writes is left unprotected by
the claim.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Callable
from pathlib import Path

import pytest

from azgym import cli

pytest.importorskip("matplotlib")

NAVIGATE = "azgym/Navigate-WarehouseSmall-v2"
SWEEP = """suites = ["warehouse-static"]
seeds = [7]
quick = true

[[localizer]]
name = "lsq"
"""


def files_in(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder``, by its path relative to it (``/`` separators)."""
    return {path.relative_to(folder).as_posix(): path.read_bytes()
            for path in sorted(folder.rglob("*")) if path.is_file()}


def exactly_covered(written: dict[str, bytes], names: tuple[str, ...]) -> None:
    """Every file written is one of ``names`` (glob patterns), and every name was written."""
    assert written
    for name in written:
        assert any(fnmatch.fnmatchcase(name, pattern) for pattern in names), (name, names)
    for pattern in names:
        assert any(fnmatch.fnmatchcase(name, pattern) for name in written), (pattern, written)


def each_one_refused(argv: list[str], written: dict[str, bytes], tmp_path: Path,
                     capsys: pytest.CaptureFixture[str]) -> None:
    """The command refuses a folder holding any single file a run wrote, naming it."""
    for k, (name, data) in enumerate(written.items()):
        out = tmp_path / f"again-{k}"
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_bytes(data)
        assert cli.main([*argv, "--out", str(out)]) == 2, name
        error = capsys.readouterr().err
        assert str(out / name) in error and "--overwrite" in error, (name, error)
        assert files_in(out) == {name: data}


def run_command(argv: list[str]) -> Callable[[Path], None]:
    """A small run of the command into a folder."""
    def run(out: Path) -> None:
        assert cli.main([*argv, "--out", str(out)]) == 0
    return run


def test_reproduce_paper(tmp_path, capsys):
    from azgym.bench.run.runner import Contender
    from azgym.bench.suites.paper import ProtocolConfig
    from azgym.experiments.paper.report import PAPER_FILES, write_outputs
    from azgym.experiments.paper.reproduce import reproduce

    # What the command writes, at a tiny size (the command's own run takes about 10 s).
    tiny = ProtocolConfig(grid_step=4, realisations=1, outlier_counts=(0, 1), seed=3)
    write_outputs(reproduce(config=tiny, contenders=[Contender("ransac", "ransac"),
                                                     Contender("lsq", "lsq")]), tmp_path / "run")
    written = files_in(tmp_path / "run")
    exactly_covered(written, PAPER_FILES)
    each_one_refused(["reproduce", "paper", "--quick", "--workers", "1"], written, tmp_path,
                     capsys)


@pytest.mark.parametrize(("argv", "writer"), [
    (["reproduce", "plotter", "--runs", "1"], "azgym.experiments.plotter.figure:PLOTTER_FILES"),
    (["study", "error-model", "--frames", "2"],
     "azgym.experiments.error_model:ERROR_MODEL_FILES"),
    (["layout", "analyze", "paper-room", "--step", "3", "--frames", "2", "--workers", "1"],
     "azgym.placement.analysis:ANALYSIS_FILES"),
], ids=["reproduce-plotter", "study-error-model", "layout-analyze"])
def test_a_command_writes_and_claims_its_writers_names(argv, writer, tmp_path, capsys):
    import importlib

    module, _, name = writer.partition(":")
    names = getattr(importlib.import_module(module), name)
    run_command(argv)(tmp_path / "run")
    written = files_in(tmp_path / "run")
    exactly_covered(written, names)
    each_one_refused(argv, written, tmp_path, capsys)


def test_sweep(tmp_path, capsys):
    from azgym.bench.sweep.run import SWEEP_FILES

    config = tmp_path / "sweep.toml"
    config.write_text(SWEEP)
    argv = ["sweep", str(config), "--workers", "1"]
    run_command(argv)(tmp_path / "run")
    written = files_in(tmp_path / "run")
    exactly_covered(written, SWEEP_FILES)
    each_one_refused(argv, written, tmp_path, capsys)


def test_layout_optimize(tmp_path, capsys):
    from azgym.placement.scenario_file import placement_files

    argv = ["layout", "optimize", "paper-room", "--add", "1", "--step", "3"]
    run_command(argv)(tmp_path / "run")
    written = files_in(tmp_path / "run")
    exactly_covered(written, placement_files("paper-room"))
    each_one_refused(argv, written, tmp_path, capsys)


@pytest.mark.slow
def test_train_navigator(tmp_path, capsys, monkeypatch):
    pytest.importorskip("stable_baselines3", reason='needs pip install "azgym[rl]"')
    from azgym.learn.navigator import train

    # What the command writes, at a tiny size (the command scores its policy on 50 episodes).
    train.train_navigator(NAVIGATE, "ppo", 256, tmp_path / "run", n_envs=1, eval_episodes=1,
                          eval_every=128, checkpoint_every=128, score_episodes=1,
                          overrides={"n_steps": 128, "batch_size": 64}, verbose=False)
    written = files_in(tmp_path / "run")
    exactly_covered(written, train.NAVIGATOR_FILES)

    def no_training(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("training started")

    monkeypatch.setattr(train, "run", no_training)
    each_one_refused(["train", "navigator", "--env", NAVIGATE, "--algo", "ppo", "--steps", "1"],
                     written, tmp_path, capsys)


def test_bench_mapping(tmp_path, capsys, monkeypatch):
    # The run is the invented one (no mapper runs): what is written is the command's writing.
    from mapping_files import hand_result

    import azgym.bench.mapping.benchmark as benchmark
    from azgym.bench.mapping.report import MAPPING_FILES

    monkeypatch.setattr(benchmark, "run_mapping", lambda *_args, **_kwargs: hand_result())
    argv = ["bench", "mapping", "--quick", "--workers", "1"]
    run_command(argv)(tmp_path / "run")
    written = files_in(tmp_path / "run")
    exactly_covered(written, MAPPING_FILES)
    each_one_refused(argv, written, tmp_path, capsys)
