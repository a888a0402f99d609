"""The README's worked example runs as written: plug in, check, benchmark, submit."""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import azgym
from azgym.bench.run.contenders import resolve_contenders
from azgym.cli import main
from azgym.localize.learned import NG_RANSAC_WEIGHTS as SHIPPED_WEIGHTS

README = Path(__file__).parent.parent / "README.md"
REFERENCES = Path(__file__).parent.parent / "leaderboard" / "entries"


def plugin_source() -> str:
    text = README.read_text(encoding="utf-8")
    section = text.split("## Plug in your localizer", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_plugin_example_checks_benchmarks_and_submits_beside_the_references(
        tmp_path, monkeypatch, capsys):
    """The recipe as written, run in a folder below a board holding reference entries, on the
    full (not quick) size of a smaller suite: the entry is ranked in the references' table."""
    source = plugin_source()
    assert len(source.strip().splitlines()) <= 32
    (tmp_path / "my_localizer.py").write_text(source)
    entries = tmp_path / "leaderboard" / "entries"
    entries.mkdir(parents=True)
    for reference in ("ransac", "lsq"):
        for file in (REFERENCES / f"{reference}-stress.json",
                     REFERENCES / f"{reference}-stress.frames.csv.gz"):
            shutil.copy(file, entries / file.name)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    import my_localizer

    azgym.check_localizer(my_localizer.MedianOfTriplets())
    section = README.read_text(encoding="utf-8").split("## Plug in your localizer", 1)[1]
    shell = re.search(r"```bash\n(.*?)```", section, re.S).group(1).replace("\\\n", " ")
    commands = [shlex.split(line) for line in shell.splitlines() if line.startswith("azgym")]
    assert [c[1] for c in commands] == ["check", "bench", "leaderboard", "leaderboard"]
    bench = commands[1]
    assert "--quick" not in bench and bench[bench.index("--suite") + 1] == "warehouse-static"
    capsys.readouterr()
    assert main(commands[0][1:]) == 0
    assert "MedianOfTriplets passed all 6 checks" in capsys.readouterr().out
    bench[bench.index("--suite") + 1] = "stress"  # the full size of a smaller suite
    assert main([*bench[1:], "--workers", "1"]) == 0
    label = "my_localizer.py:MedianOfTriplets:max_triplets=100"  # the table shows the spec
    assert re.search(rf"^ *\d+ {re.escape(label)} ", capsys.readouterr().out, re.M)
    assert main(commands[2][1:]) == 0
    assert main(commands[3][1:]) == 0
    printed = capsys.readouterr()
    assert "warning" not in printed.err  # a full run, beside the references: nothing to warn of
    assert (entries / "median-of-triplets.json").is_file()
    board = (tmp_path / "leaderboard" / "README.md").read_text()
    ranking = board.split("## stress", 1)[1].split("### dev split, full size", 1)[1]
    ranking = ranking.split("\n#", 1)[0]  # the one table: up to the next heading
    for name in ("median-of-triplets", "ransac-stress", "lsq-stress"):
        assert name in ranking
    sys.modules.pop("my_localizer", None)


def python_blocks() -> list[tuple[str, str]]:
    """Every python example of the README outside the plug-in section, with its section."""
    text = README.read_text(encoding="utf-8").split("## Plug in your localizer", 1)[0]
    blocks = []
    for section in text.split("\n## ")[1:]:
        title = section.splitlines()[0]
        blocks += [(title, code) for code in re.findall(r"```python\n(.*?)```", section, re.S)]
    return blocks


@pytest.mark.parametrize(("section", "code"), python_blocks(),
                         ids=[title for title, _ in python_blocks()])
def test_every_python_example_runs_as_written(section, code, tmp_path):
    """Each in a fresh interpreter, as a reader runs it: what an earlier test imported (the
    environment ids ``import azgym.envs`` registers, say) must not make an example pass."""
    example = tmp_path / "example.py"
    example.write_text(code, encoding="utf-8")
    done = subprocess.run([sys.executable, str(example)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, f"README.md ({section}):\n{done.stderr[-3000:]}"


def test_every_localizer_spec_the_readme_gives_builds(tmp_path, monkeypatch):
    """Every ``--localizer``, ``azgym check`` and quoted spec of the README is one azgym takes
    (the README's own plug-in file in place, a placeholder ``path/to/`` file written there)."""
    text = README.read_text(encoding="utf-8")
    specs = {spec for spec in re.findall(r"(?:--localizer|azgym check) ([^\s`]+)", text)
             if not spec.isupper()  # not the SPEC of a usage line
             and spec != "truth"}  # the navigation environments' oracle, not a localizer
    specs |= {spec for spec in re.findall(r"`([\w./-]+:[\w:=.,-]+)`", text) if "=" in spec}
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my_localizer.py").write_text(plugin_source())
    tracker_section = text.split("## Trackers", 1)[1]
    (tmp_path / "hold_last.py").write_text(
        re.search(r"```python\n(.*?)```", tracker_section, re.S).group(1))
    (tmp_path / "path" / "to").mkdir(parents=True)
    (tmp_path / "runs" / "ng-ransac").mkdir(parents=True)  # what the README's training writes
    shutil.copy(SHIPPED_WEIGHTS, tmp_path / "runs" / "ng-ransac" / "ng-ransac.npz")
    (tmp_path / "path" / "to" / "mine.py").write_text("".join(
        f"class {name}:\n    def __init__(self, *, tag=''):\n        pass\n\n"
        "    def localize(self, measurements, beacons):\n        pass\n\n\n"
        for name in ("Mine", "MyLocalizer")))
    assert {"ransac:weighted=true", "my_localizer.py:MedianOfTriplets",
            "ransac:max_iter=20"} <= specs
    for spec in sorted(specs):
        (contender,) = resolve_contenders([spec], with_builtins=False)
        assert resolve_contenders([contender.label], with_builtins=False) == [contender], spec


def test_the_tracker_example_runs_on_the_routes_and_holds_through_dropouts(tmp_path, capsys):
    section = README.read_text(encoding="utf-8").split("## Trackers", 1)[1]
    source = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    assert sum(1 for line in source.splitlines() if line.strip()) <= 30  # lines of code
    (tmp_path / "hold_last.py").write_text(source)
    command = re.search(r"`(azgym bench --suite route-events [^`]*)`", section).group(1)
    argv = shlex.split(command)[1:]
    argv[argv.index("hold_last.py:HoldLast")] = f"{tmp_path / 'hold_last.py'}:HoldLast"
    assert main([*argv, "--workers", "1", "--out", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    label = f"{tmp_path / 'hold_last.py'}:HoldLast"
    rows = {line.split()[1]: line.split() for line in printed.splitlines()
            if re.match(r"^ *\d+ \S", line)}
    def availability(row):  # the first percentage of a row: avail
        return float(next(cell for cell in row[2:] if cell.endswith("%")).rstrip("%"))

    held, ransac = availability(rows[label]), availability(rows["ransac"])
    assert held > ransac  # holding the last fix answers frames ransac cannot
    assert "tracks:" in printed


def test_the_learned_section_trains_a_model_and_benches_it_beside_the_shipped_one(
        tmp_path, monkeypatch, capsys):
    pytest.importorskip("torch", reason="training needs pip install torch==2.13.0")
    section = README.read_text(encoding="utf-8").split("## Learned localizers", 1)[1]
    shell = re.search(r"```bash\n(.*?)```", section, re.S).group(1)
    commands = [shlex.split(line.split("#")[0]) for line in shell.splitlines()
                if line.startswith("azgym")]
    assert [c[1] for c in commands] == ["train", "bench"]
    monkeypatch.chdir(tmp_path)  # the weights path is relative: the workers must resolve it here
    train = commands[0]
    for option, small in (("--layouts", "4"), ("--frames-per-layout", "10"), ("--epochs", "2")):
        train[train.index(option) + 1] = small
    assert main(train[1:]) == 0
    assert main([*commands[1][1:], "--quick", "--workers", "1", "--out", "out"]) == 0
    printed = capsys.readouterr().out
    rows = {line.split()[1] for line in printed.splitlines() if re.match(r"^ *\d+ \S", line)}
    assert {"ng-ransac", "ng-ransac:weights=runs/ng-ransac/ng-ransac.npz", "ransac"} <= rows


def test_the_navigator_section_scores_the_shipped_policy_trains_and_quotes_its_card(
        tmp_path, monkeypatch, capsys):
    """The commands run as written (training stopped at its checked request: a full run is the
    model card's), and the figures quoted are the shipped policy's card's."""
    pytest.importorskip("stable_baselines3", reason="needs the rl extra")
    from azgym.learn.navigator import train
    from azgym.nav.policy_file import MODELS, SHIPPED_FILES

    section = README.read_text(encoding="utf-8").split("## Train a navigator", 1)[1]
    section = section.split("\n## ", 1)[0]
    assert len([line for line in section.splitlines() if line.strip()]) <= 10
    shell = re.search(r"```bash\n(.*?)```", section, re.S).group(1)
    commands = [shlex.split(line) for line in shell.splitlines()]
    assert [c[1:3] for c in commands] == [["evaluate", "navigator"], ["train", "navigator"],
                                          ["evaluate", "navigator"]]
    monkeypatch.chdir(tmp_path)
    short = ["--episodes", "2", "--seed", "2300"]
    assert main([*commands[0][1:], *short]) == 0
    rows = {line.split()[0]: float(line.split()[1])
            for line in capsys.readouterr().out.splitlines()[1:] if line}
    assert set(rows) == {"truth", "ransac", "lsq"} and rows["truth"] == 100.0
    requests = []
    monkeypatch.setattr(train, "run", lambda request: requests.append(request) or
                        train.TrainingResult(*"pcue", wall_time=1.0, score={}))
    assert main(commands[1][1:]) == 0
    (request,) = requests
    assert (request.steps, request.seed, request.n_envs, request.threads) == (1_000_000, 0, 4, 1)
    trained = tmp_path / "runs" / "navigator" / "policy.zip"
    trained.write_bytes((MODELS / SHIPPED_FILES[False]).read_bytes())
    assert main([*commands[2][1:], *short]) == 0
    card = (MODELS / SHIPPED_FILES[False]).with_suffix(".md").read_text(encoding="utf-8")
    quoted = re.search(r"shipped PPO policy: ([\d.]+) %, ([\d.]+) % and ([\d.]+) % success",
                       section).groups()
    for localizer, success in zip(("truth", "ransac", "lsq"), quoted, strict=True):
        assert f"| {localizer} | {success} % [" in card


def test_the_logged_data_section_scores_the_shipped_log(tmp_path, monkeypatch, capsys):
    section = README.read_text(encoding="utf-8").split("## Logged data", 1)[1]
    section = section.split("\n## ", 1)[0]
    command = re.search(r"`(azgym bench --data [^`]*)`", section).group(1)
    monkeypatch.chdir(tmp_path)
    argv = shlex.split(command)[1:]
    assert main([*argv, "--localizer", "ransac", "--workers", "1", "--out", "out"]) == 0
    row = re.search(r"^ *1 ransac +(.*)$", capsys.readouterr().out, re.M).group(1).split()
    assert (tmp_path / "out" / "results.json").is_file()
    said = re.search(r"ransac's answered\s+median is ([0-9.]+) cm at ([0-9.]+) % availability",
                     section)
    assert (row[4], row[2]) == (said.group(1), f"{float(said.group(2)):.1f}%"), row


@pytest.mark.slow
def test_the_robot_recipe_prints_the_figures_the_readme_gives(tmp_path, monkeypatch, capsys):
    """Calibrated on robot-arena's long route, the trackers on wander-2: the README's figures."""
    section = README.read_text(encoding="utf-8").split("## Logged data", 1)[1]
    section = section.split("\n## ", 1)[0]
    shell = re.search(r"```bash\n(.*?)```", section, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    for line in shell.splitlines():
        assert main(shlex.split(line)[1:]) == 0, line
    table = capsys.readouterr().out
    p95 = re.search(r"with a p95 of ([0-9.]+) cm; ransac, frame by\s+frame, answers "
                    r"([0-9.]+) %", section)
    for tracker in ("gated-ekf", "robust"):
        row = re.search(rf"^ *[0-9]+ {tracker} +(.*)$", table, re.M).group(1).split()
        assert row[2] == "100.0%" and row[6] == p95.group(1), row
    ransac = re.search(r"^ *[0-9]+ ransac +(.*)$", table, re.M).group(1).split()
    assert ransac[2] == f"{p95.group(2)}%", ransac


def test_the_layout_section_analyzes_and_optimizes(tmp_path, monkeypatch):
    section = README.read_text(encoding="utf-8").split("## Plan a beacon layout", 1)[1]
    shell = re.search(r"```bash\n(.*?)```", section.split("\n## ", 1)[0], re.S).group(1)
    commands = [shlex.split(line.split("#")[0]) for line in shell.splitlines()]
    assert [c[1:3] for c in commands] == [["layout", "analyze"], ["layout", "optimize"]]
    monkeypatch.chdir(tmp_path)
    coarse = ["--step", "2", "--no-figures"]  # the commands as written, on a coarse grid
    assert main([*commands[0][1:], *coarse, "--frames", "5"]) == 0
    assert main([*commands[1][1:], *coarse]) == 0
    assert list(tmp_path.glob("results/layout/**/*.toml"))


def test_the_sweep_the_readme_names_is_a_valid_config():
    from azgym.bench.sweep.config import load_sweep

    section = README.read_text(encoding="utf-8").split("## Beyond one machine", 1)[1]
    path = re.search(r"`azgym sweep (\S+\.toml)`", section).group(1)
    config = load_sweep(README.parent / path)
    assert len(config.points) >= 2 and config.suites
