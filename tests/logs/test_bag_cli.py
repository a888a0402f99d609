"""azgym import bag and azgym export bag on the command line, and docs/ros2.md's recipe."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from logs.bag_helpers import Messages, log_topics, ns_of, same_logs, store, write_bag

from azgym.cli import main
from azgym.logs import read_log
from azgym.logs.ros.messages import DETECTIONS_MSG

ROOT = Path(__file__).resolve().parents[2]
DOCS = (ROOT / "docs" / "ros2.md").read_text()


def _robot_bag(folder: Path) -> Path:
    """A robot's bag as the recipe starts from: no azgym manifest, truth on /mocap/pose."""
    topics = log_topics(read_log("warehouse-small-simulated"), Messages(store()),
                        manifest=False)
    topics["/mocap/pose"] = topics.pop("/azgym/truth")
    return write_bag(folder / "robot-bag", topics)


def test_the_docs_recipe_runs_from_a_bag_to_a_scored_log_and_back(tmp_path, monkeypatch,
                                                                  capsys):
    recipe = DOCS.split("## The recipe", 1)[1].split("```", 2)[1]
    lines = [line for line in recipe.splitlines() if line.startswith("azgym ")]
    assert len(recipe.strip().splitlines()) <= 10 and len(lines) == 6
    monkeypatch.chdir(tmp_path)
    _robot_bag(tmp_path)
    for line in lines:
        assert main(shlex.split(line.split("#")[0])[1:]) == 0, line
    printed = capsys.readouterr().out
    assert "robot-bag: real data, log format 2; imported from the ROS bag robot-bag" in printed
    assert "truth: x, y, heading on every frame (ROS bag topic /mocap/pose" in printed
    assert (tmp_path / "results" / "robot-log" / "results.json").is_file()
    same_logs(read_log("robot-log"), read_log("robot-log-again"))
    assert sorted(path.name for path in Path("sim-bag").iterdir()) == \
        ["metadata.yaml", "sim-bag.db3"]


def test_the_docs_print_the_message_definition_the_code_registers():
    assert DETECTIONS_MSG in DOCS


def test_import_checks_a_log_as_before_and_a_folder_named_bag_too(mini_log, tmp_path, capsys,
                                                                  monkeypatch):
    assert main(["import", str(mini_log)]) == 0
    assert "mini: SIMULATED data" in capsys.readouterr().out
    mini_log.rename(tmp_path / "bag")
    monkeypatch.chdir(tmp_path)
    assert main(["import", "bag"]) == 0
    assert "mini: SIMULATED data" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "message"), [
    (["import", "LOG", "--out", "x"], "--out: for azgym import bag BAG only"),
    (["import", "LOG", "--map", "m", "--simulated"], "--map, --simulated: for azgym import bag"),
    (["import", "LOG", "BAG"], "import LOG BAG: give a log's folder"),
    (["import", "bag", "BAG"], "--out: name the log folder to write"),
    (["import", "bag", "BAG", "--out", "o", "--topic", "odometry"], "--topic: 'odometry' is "
                                                                     "not NAME=VALUE"),
    (["import", "bag", "BAG", "--out", "o", "--ids-field", "a.b"], "--ids-field, "
                                                                    "--azimuths-field: a user's"),
    (["import", "bag", "BAG", "--out", "o", "--max-gap", "0"], "--max-gap"),
])
def test_import_bag_options_are_refused_by_name(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_import_bag_never_replaces_a_log_without_overwrite(tmp_path, capsys):
    bag = _robot_bag(tmp_path)
    out = tmp_path / "log"
    assert main(["import", "bag", str(bag), "--out", str(out), "--map", "warehouse-small"]) == 0
    before = {path.name: path.read_bytes() for path in out.iterdir()}
    assert main(["import", "bag", str(bag), "--out", str(out), "--map", "warehouse-small"]) == 2
    assert "already exist; nothing was written" in capsys.readouterr().err
    assert {path.name: path.read_bytes() for path in out.iterdir()} == before
    assert main(["import", "bag", str(bag), "--out", str(out), "--map", "warehouse-small",
                 "--name", "renamed", "--overwrite"]) == 0
    assert read_log(out).manifest.name == "renamed"


def test_export_bag_claims_its_folder_and_refuses_route_options_with_data(tmp_path, capsys):
    out = tmp_path / "bag"
    assert main(["export", "bag", "--data", "warehouse-small-simulated", "--out", str(out)]) == 0
    assert main(["export", "bag", "--data", "warehouse-small-simulated", "--out", str(out)]) == 2
    assert "bag.db3" in capsys.readouterr().err
    assert main(["export", "bag", "--data", "warehouse-small-simulated", "--out", str(out),
                 "--storage", "mcap", "--overwrite"]) == 2
    assert "bag.db3 belong to the bag there and would be left" in capsys.readouterr().err
    assert main(["export", "bag", "--data", "warehouse-small-simulated", "--out", str(out),
                 "--storage", "mcap2"]) == 2
    assert "storage: 'mcap2' is none of sqlite3, mcap" in capsys.readouterr().err
    assert main(["export", "bag", "--data", "warehouse-small-simulated", "--seed", "3",
                 "--out", str(tmp_path / "b2")]) == 2
    assert "--seed: options of a simulated route" in capsys.readouterr().err
    assert not (tmp_path / "b2").exists()


def test_import_azgym_and_the_command_load_no_rosbags_and_say_how_to_install_it(tmp_path):
    code = ("import sys, azgym, azgym.cli, azgym.logs.ros; azgym.cli.build_parser(); "
            "print('rosbags' in ' '.join(sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.stdout.strip() == "False", done.stderr
    code = ("import sys; sys.modules['rosbags'] = None; from azgym.cli import main; "
            f"sys.exit(main(['import', 'bag', {str(tmp_path)!r}, '--out', 'x']))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2
    assert re.search(r'rosbags is not installed; run: pip install "azgym\[ros\]"', done.stderr)
    assert not (tmp_path / "x").exists()


def test_a_bag_with_one_message_per_topic_kind_and_epoch_times_round_trips(tmp_path):
    make = Messages(store())
    t = 1_772_611_200.123456789
    bag = write_bag(tmp_path / "bag", {"/azgym/detections": (
        "azgym_msgs/msg/BeaconAzimuths", [(ns_of(t), make.detections(t, 7, [1], [0.5]))])})
    assert main(["import", "bag", str(bag), "--out", str(tmp_path / "log"), "--map",
                 "warehouse-small"]) == 0
    log = read_log(tmp_path / "log")
    assert log.frames["time"][0] == t and log.frames["frame"].tolist() == [7]
