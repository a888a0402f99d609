"""Leaderboard entries: what a sound entry is, and every way a bad one is caught."""

from __future__ import annotations

import csv
import dataclasses
import gzip
import hashlib
import html
import io
import json
import math
import re
import shutil
import subprocess

import pytest

from azgym.bench.leaderboard import board as B
from azgym.bench.leaderboard import checks
from azgym.bench.leaderboard import entries as L
from azgym.bench.leaderboard.checks import clean, suite_cases
from azgym.bench.leaderboard.entry_files import parse_frames
from azgym.bench.navigation.benchmark import contenders_of
from azgym.bench.navigation.results_file import load_navigation
from azgym.bench.navigation.suites import NAVIGATION_SUITES, NAVIGATORS
from azgym.bench.report.results import contender_metrics
from azgym.bench.run.runner import Contender, run_benchmark
from azgym.bench.suites import get_suite
from azgym.cli import main
from azgym.localize.registry import list_trackers

NAVIGATION = L.Path(__file__).parents[2] / "leaderboard" / "navigation"


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    run_benchmark(get_suite("stress"), [Contender("ransac", "ransac"), Contender("lsq", "lsq")],
                  quick=True).write(out)
    return out


@pytest.fixture
def entry_path(results, tmp_path):
    return L.submit(results, "lsq", tmp_path / "entries", name="lsq-ref", version="1.0",
                    authors=["A. Author"], link="https://example.org")


def test_submitted_text_cannot_forge_a_row_or_inject_html(results, tmp_path):
    entries = tmp_path / "entries"
    forged = "x | 0.00 |\n| 1 | evil | 9 | me | 100.0 | 0.00 |"
    L.submit(results, "lsq", entries, name="lsq-ref", version="1<script>alert(1)</script>",
             authors=[forged, "B|C"], link="https://example.org/a(b)")
    readme, page = B.build(entries, tmp_path / "board")
    table = [line for line in readme.read_text().splitlines() if line.startswith("| ")]
    assert len(table) == 2  # the header and the one entry, no forged row
    row = table[1]
    cells = re.split(r"(?<!\\)\|", row)[1:-1]  # split on unescaped pipes only
    assert len(cells) == len(B.COLUMNS)
    assert "<script>" not in readme.read_text() and "&lt;script&gt;" in row
    assert "(https://example.org/a%28b%29)" in row
    text = page.read_text()
    assert "<script>alert" not in text and '<a href="https://example.org/a%28b%29">' in text


@pytest.mark.parametrize("link", ["javascript:alert(1)", "file:///etc/passwd", "built into azgym"])
def test_a_link_must_be_a_web_address_and_others_are_never_shown(results, tmp_path, link):
    with pytest.raises(L.LeaderboardError, match="link: must be an http:// or https:// address"):
        L.submit(results, "lsq", tmp_path / "entries", name="bad-link", version="1",
                 authors=["a"], link=link)
    assert B.web_link(link) is None


def test_building_from_a_missing_or_empty_folder_keeps_the_board(tmp_path):
    board = tmp_path / "board"
    for folder in (tmp_path / "typo", tmp_path / "empty"):
        (tmp_path / "empty").mkdir(exist_ok=True)
        with pytest.raises(L.LeaderboardError, match="no leaderboard entries there"):
            B.build(folder, board)
    assert not board.exists()


def test_a_submitted_entry_validates_builds_and_reproduces(entry_path, tmp_path):
    entry = L.load_entry(entry_path)
    assert entry["name"] == "lsq-ref" and entry["localizer"] == {"spec": "lsq", "params": {}}
    assert (entry_path.parent / "lsq-ref.frames.csv.gz").is_file()
    readme, page = B.build(entry_path.parent, tmp_path / "board")
    assert "| 1 | [lsq-ref](https://example.org) | 1.0 | A. Author |" in readme.read_text()
    text = page.read_text()
    assert "data:image/png;base64," in text  # the suite's error CDFs, embedded
    assert "<table class=\"board\"" in text and "<script>" in text and "http" not in text.split(
        "<script>")[1]  # self-contained: no external resources
    assert L.verify(entry_path) == {}


def rewrite(path, change):
    entry = json.loads(path.read_text())
    change(entry)
    path.write_text(json.dumps(entry))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda e: e.pop("authors"), "(top level): 'authors' is a required property"),
        (lambda e: e.update(seed="7"), "seed: '7' is not of type 'integer'"),
        (lambda e: e["metrics"]["all"].update(mean_cm=1.0),
         "metrics/all/mean_cm: the entry says 1.0, its per-frame results give"),
        (lambda e: e.update(suite_version=99), "suite_version: stress is at version 1"),
        (lambda e: e.update(suite="nonsense"), "suite: unknown suite 'nonsense'"),
        (lambda e: e.update(results_sha256="0" * 64), "results_sha256: the per-frame results"),
        (lambda e: e.update(name="bad name!"), "name: 'bad name!' does not match"),
        (lambda e: e.update(format=2), "format: the entry is in format 2, this azgym reads "
                                       "format 4; make it again"),
        (lambda e: e["metrics"].pop("tracking"), "metrics: 'tracking' is a required property"),
    ],
)
def test_malformed_or_tampered_entries_are_rejected_with_the_reason(entry_path, change, message):
    rewrite(entry_path, change)
    with pytest.raises(L.LeaderboardError, match=re.escape(message)):
        L.load_entry(entry_path)


def test_a_tampered_frames_file_is_caught(entry_path):
    frames = entry_path.parent / "lsq-ref.frames.csv.gz"
    lines = gzip.decompress(frames.read_bytes()).decode().splitlines()
    cells = lines[1].split(",")
    cells[6] = "0.0"  # claim a perfect estimate on the first frame
    frames.write_bytes(gzip.compress(("\n".join([lines[0], ",".join(cells), *lines[2:]])
                                      + "\n").encode()))
    with pytest.raises(L.LeaderboardError, match="results_sha256: the per-frame results file"):
        L.load_entry(entry_path)


def test_missing_frames_file_and_invalid_json(entry_path):
    (entry_path.parent / "lsq-ref.frames.csv.gz").unlink()
    with pytest.raises(L.LeaderboardError, match="results_file: lsq-ref.frames.csv.gz is missing"):
        L.load_entry(entry_path)
    entry_path.write_text("{not json")
    with pytest.raises(L.LeaderboardError, match="not valid JSON"):
        L.load_entry(entry_path)


def test_submit_refuses_unknown_localizers_and_overwrites(results, entry_path):
    with pytest.raises(L.LeaderboardError, match="no localizer 'mex' in the results"):
        L.submit(results, "mex", entry_path.parent, name="x", version="1", authors=["a"])
    with pytest.raises(L.LeaderboardError, match="an entry of that name exists"):
        L.submit(results, "lsq", entry_path.parent, name="lsq-ref", version="1", authors=["a"])



PLUGIN = """from azgym.localize.lsq import LeastSquares


class Plug(LeastSquares):
    \"\"\"lsq, from a file.\"\"\"
"""


def plugin_entry(tmp_path, monkeypatch, attribute="Plug"):
    """An entry of a plug-in file, run from its own folder and submitted to another."""
    work = tmp_path / "work"
    work.mkdir()
    (work / "plug.py").write_text(PLUGIN)
    monkeypatch.chdir(work)
    run_benchmark(get_suite("stress"), [Contender("plug", f"plug.py:{attribute}")],
                  quick=True).write(work / "out", figures=False)
    path = L.submit(work / "out", "plug", tmp_path / "site" / "entries", name="plug",
                    version="1", authors=["a"])
    monkeypatch.chdir(tmp_path / "site")  # verify runs from elsewhere
    return work / "plug.py", path


def test_a_plugin_entry_verifies_from_any_folder_and_names_a_changed_or_missing_file(
        tmp_path, monkeypatch):
    plugin, path = plugin_entry(tmp_path, monkeypatch)
    stored = json.loads(path.read_text())["localizer"]
    assert stored["spec"] == "../../work/plug.py:Plug"  # relative to the entry's folder
    assert stored["sha256"] == hashlib.sha256(plugin.read_bytes()).hexdigest()
    assert L.verify(path) == {}
    plugin.write_text(PLUGIN + "# changed\n")
    with pytest.raises(L.LeaderboardError, match="localizer/sha256: plug-in file changed since "
                       "the entry was made: sha256 [0-9a-f]{64}, the entry was scored with"):
        L.verify(path)
    plugin.unlink()
    with pytest.raises(L.LeaderboardError, match=r"localizer/spec: the plug-in file \S+plug.py "
                       "does not exist .a plug-in is named relative to the entry's folder"):
        L.verify(path)


def test_submit_refuses_a_plugin_file_changed_since_the_run(tmp_path, monkeypatch):
    plugin, _ = plugin_entry(tmp_path, monkeypatch)
    plugin.write_text(PLUGIN + "# changed\n")
    with pytest.raises(L.LeaderboardError, match="plug-in file changed since the run"):
        L.submit(tmp_path / "work" / "out", "plug", tmp_path / "site" / "entries",
                 name="plug2", version="1", authors=["a"])


def test_verify_says_why_a_localizer_cannot_run(tmp_path, monkeypatch):
    _, path = plugin_entry(tmp_path, monkeypatch, attribute="Missing")
    with pytest.raises(L.LeaderboardError, match="could not run on any frame: cannot build "
                       ".*has no attribute 'Missing'"):
        L.verify(path)


def test_a_consistent_forgery_passes_the_checks_and_verify_catches_it(entry_path):
    # Halve every error (each estimate moved halfway to the truth, so that its errors are the
    # row's) and redo the bookkeeping: the figures match the forged rows, so only a rerun can
    # tell.
    frames = entry_path.parent / "lsq-ref.frames.csv.gz"
    rows = list(csv.reader(io.StringIO(gzip.decompress(frames.read_bytes()).decode())))[1:]
    entry = json.loads(entry_path.read_text())
    _, cases = suite_cases("stress", entry["suite_version"], entry["seed"], entry["quick"])
    for row, case in zip(rows, cases, strict=True):
        if row[5] == "1":
            row[6] = repr(float(row[6]) / 2)
            row[10], row[11] = (repr(true + (float(value) - true) / 2)
                                for value, true in zip(row[10:12], case.pose[:2], strict=True))
    text = L.frames_file_text(rows)
    frames.write_bytes(gzip.compress(text.encode()))
    table = parse_frames(text, "forged")
    entry["results_sha256"] = hashlib.sha256(text.encode()).hexdigest()
    entry["metrics"] = clean(contender_metrics(table.outcome, cases,
                                               entry["metrics"]["runtime_us"]["reference_us"]))
    entry_path.write_text(json.dumps(entry))
    assert L.load_entry(entry_path)["name"] == "lsq-ref"
    differences = L.verify(entry_path)
    assert "all/p75_cm" in differences and "by_group/warehouse-large, heavy/mean_cm" in differences


def test_submit_never_replaces_another_entrys_files(results, entry_path):
    entries = entry_path.parent
    victim = json.loads(entry_path.read_text())
    victim["results_file"] = "other.frames.csv.gz"  # hand-written: it claims that file
    entry_path.write_text(json.dumps(victim))
    (entries / "other.frames.csv.gz").write_bytes(b"the victim's results")
    with pytest.raises(L.LeaderboardError, match="lsq-ref.json: that entry's results_file is "
                       "other.frames.csv.gz; submit will not replace another entry's files"):
        L.submit(results, "lsq", entries, name="other", version="1", authors=["a"],
                 overwrite=True)
    assert (entries / "other.frames.csv.gz").read_bytes() == b"the victim's results"
    with pytest.raises(L.LeaderboardError, match=r"lsq-ref\.\S+: another entry's file, whose "
                       "name differs from 'LSQ-ref''s only in case"):
        L.submit(results, "lsq", entries, name="LSQ-ref", version="1", authors=["a"],
                 overwrite=True)
    (entries / "orphan.frames.csv.gz").write_bytes(b"whose?")
    with pytest.raises(L.LeaderboardError, match="orphan.frames.csv.gz: an entry of that name "
                       "exists"):
        L.submit(results, "lsq", entries, name="orphan", version="1", authors=["a"])
    assert (entries / "orphan.frames.csv.gz").read_bytes() == b"whose?"


def test_names_must_differ_in_more_than_case(entry_path, tmp_path):
    entries = entry_path.parent
    entry = json.loads(entry_path.read_text())
    entry.update(name="LSQ-REF", results_file="LSQ-REF.frames.csv.gz")
    (entries / "LSQ-REF.json").write_text(json.dumps(entry))
    shutil.copy(entries / "lsq-ref.frames.csv.gz", entries / "LSQ-REF.frames.csv.gz")
    with pytest.raises(L.LeaderboardError, match="name: 'lsq-ref' and 'LSQ-REF' differ only in "
                       "case"):
        B.build(entries, tmp_path / "board")


def test_missing_files_and_deep_json_are_named_errors(results, entry_path, tmp_path):
    with pytest.raises(L.LeaderboardError, match="nowhere.json: no such leaderboard entry"):
        L.verify(tmp_path / "nowhere.json")
    with pytest.raises(L.LeaderboardError, match="nowhere: no such folder"):
        L.submit(tmp_path / "nowhere", "lsq", tmp_path / "e", name="x", version="1",
                 authors=["a"])
    bare = tmp_path / "bare"
    bare.mkdir()
    shutil.copy(results / "results.json", bare)
    with pytest.raises(L.LeaderboardError, match="frames.csv: no such frames.csv of an azgym "
                       "bench run"):
        L.submit(bare, "lsq", tmp_path / "e", name="x", version="1", authors=["a"])
    entry_path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(L.LeaderboardError, match="not valid JSON: nested deeper than 16"):
        L.load_entry(entry_path)


def test_the_verify_command_warns_first_and_names_a_missing_entry(entry_path, capsys):
    assert main(["leaderboard", "verify", str(entry_path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "rerunning its localizer 'lsq', which is azgym's own, on its own frames" in out[0]
    assert out[-1].endswith("reproduced (every accuracy figure within 1e-6)")
    assert main(["leaderboard", "verify", str(entry_path.parent / "typo.json")]) == 2
    assert "typo.json: no such leaderboard entry" in capsys.readouterr().err


def test_quick_runs_and_the_test_split_are_never_ranked_with_full_dev_runs(results, tmp_path):
    stress, entries = get_suite("stress"), tmp_path / "entries"
    for split, quick in (("dev", False), ("test", True)):
        run_benchmark(stress, [Contender("lsq", "lsq")], split=split, quick=quick).write(
            tmp_path / split, figures=False)
    L.submit(tmp_path / "dev", "lsq", entries, name="full-dev", version="1", authors=["a"])
    L.submit(tmp_path / "test", "ransac", entries, name="test-run", version="1", authors=["a"])
    L.submit(results, "ransac", entries, name="quick-dev", version="1", authors=["a"])
    readme, page = B.build(entries, tmp_path / "board")
    tables = {part.splitlines()[0]: part for part in readme.read_text().split("### ")[1:]}
    assert list(tables) == [B.KINDS[k][2] for k in (0, 1, 3)]
    for title, name in zip(tables, ("full-dev", "quick-dev", "test-run"), strict=True):
        ranked = [line for line in tables[title].splitlines() if line.startswith("| 1 ")]
        assert len(ranked) == 1 and f"| {name} |" in ranked[0]  # each alone, ranked first
    assert 'id="board-stress"' in page.read_text() and 'id="board-stress-test-quick"' in \
        page.read_text()


def body_attributes(chromium: str, harness, tmp_path) -> dict[str, str]:
    """Open the page in headless Chromium; the ``data-*`` attributes its scripts set on <body>."""
    completed = subprocess.run(
        [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
         "--disable-background-networking", "--disable-component-update", "--no-first-run",
         "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom",
         harness.as_uri()],
        capture_output=True, text=True, timeout=120, check=True)
    body = re.search(r"<body([^>]*)>", completed.stdout).group(1)
    return dict(re.findall(r'data-(\w+)="([^"]*)"', body))


@pytest.mark.slow
def test_the_board_opens_without_errors_and_sorts_in_headless_chromium(results, tmp_path):
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("Chromium is not installed (apt-get install chromium; .ci/run installs it)")
    entries = tmp_path / "entries"
    for label in ("ransac", "lsq"):
        L.submit(results, label, entries, name=f"{label}-ref", version="1", authors=["a"])
    _, page = B.build(entries, tmp_path / "board")
    column = [c for c, _ in B.COLUMNS].index("p75 cm")
    probe = f"""<script>
      var header = document.querySelectorAll("table.board th")[{column}];
      function names() {{
        return Array.prototype.map.call(document.querySelectorAll("table.board tbody tr"),
          function (row) {{ return row.cells[1].textContent; }}).join(",");
      }}
      header.click(); var up = names(); header.click(); var down = names();
      document.body.setAttribute("data-up", up); document.body.setAttribute("data-down", down);
      document.body.setAttribute("data-errors", JSON.stringify(window.pageErrors));
    </script>"""
    catcher = ('<script>window.pageErrors = []; window.addEventListener("error", function (e) '
               '{ window.pageErrors.push(e.message); });</script>')
    text = page.read_text().replace("<title>", catcher + "<title>").replace(
        "</body>", probe + "</body>")
    harness = tmp_path / "harness.html"
    harness.write_text(text)
    attributes = body_attributes(chromium, harness, tmp_path)
    assert html.unescape(attributes["errors"]) == "[]"
    p75 = {label: json.loads((entries / f"{label}-ref.json").read_text())["metrics"]["all"][
        "p75_cm"] for label in ("ransac", "lsq")}
    best, worst = sorted(p75, key=p75.get)
    assert attributes["up"] == f"{best}-ref,{worst}-ref"
    assert attributes["down"] == f"{worst}-ref,{best}-ref"


@pytest.mark.slow
def test_every_table_of_the_committed_board_sorts_both_ways_in_headless_chromium(tmp_path):
    # Each table sorts by its own column: a header's index counts within its table, not the page.
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("Chromium is not installed (apt-get install chromium; .ci/run installs it)")
    page = L.Path(__file__).parents[2] / "leaderboard" / "index.html"
    # a frame table sorts by its p75, a navigation table by its SPL, a mapping one by its p95
    probe = """<script>
      var result = [];
      document.querySelectorAll("table.board").forEach(function (table) {
        var header = Array.prototype.find.call(table.tHead.rows[0].cells, function (cell) {
          return ["p75 cm", "SPL", "p95 cm"].indexOf(cell.textContent) >= 0; });
        var column = header.cellIndex;
        function p75() {
          return Array.prototype.map.call(table.tBodies[0].rows,
            function (row) { return row.cells[column].textContent; }).join(";");
        }
        header.click(); var up = p75(); header.click(); var down = p75();
        result.push([table.id, up, down]);
      });
      document.body.setAttribute("data-result", JSON.stringify(result));
      document.body.setAttribute("data-errors", JSON.stringify(window.pageErrors));
    </script>"""
    catcher = ('<script>window.pageErrors = []; window.addEventListener("error", function (e) '
               '{ window.pageErrors.push(e.message); });</script>')
    harness = tmp_path / "harness.html"
    harness.write_text(page.read_text().replace("<title>", catcher + "<title>").replace(
        "</body>", probe + "</body>"))
    attributes = body_attributes(chromium, harness, tmp_path)
    assert json.loads(html.unescape(attributes["errors"])) == []
    tables = json.loads(html.unescape(attributes["result"]))
    navigation = [f"board-{name}-{split}-{data['seed']}-full"
                  for name in NAVIGATION_SUITES for split in ("dev", "test")
                  for data in [json.loads((NAVIGATION / f"{name}-{split}.json").read_text())]]
    logs = {e["dataset"]["name"]: e["dataset"]["simulated"]
            for e in committed_entries() if "dataset" in e}  # sound: the next test builds on them
    # The simulated logs' tables follow the suites', the real ones' come in a part of their own.
    datasets = sorted(name for name in logs if logs[name]) + \
        sorted(name for name in logs if not logs[name])
    assert [table for table, _, _ in tables] == [f"board-{suite}" for suite in L.SUITES] + [
        f"board-data-{name}" for name in datasets] + navigation + ["board-mapping-full"]
    for table, up, down in tables:
        values = [math.inf if cell == "∞" else float(cell) for cell in up.split(";")]
        assert values == sorted(values), table
        assert down.split(";") == up.split(";")[::-1], table


def committed_entries() -> list[dict]:
    """The committed entries as their files say (each one is checked as it is built on)."""
    return [json.loads(path.read_text()) for path in
            sorted((NAVIGATION.parent / "entries").glob("*.json"))]


@pytest.mark.slow
def test_the_committed_reference_entries_are_sound_and_the_board_is_up_to_date(tmp_path):
    root = L.Path(__file__).parents[2] / "leaderboard"
    # building checks every entry (the first unsound one raises) and draws the board
    readme, _ = B.build(root / "entries", tmp_path, NAVIGATION, mapping_dir=root / "mapping")
    assert readme.read_text() == (root / "README.md").read_text(), \
        "leaderboard/README.md is stale: run python baselines/leaderboard_entries.py"
    entries = committed_entries()
    builtins = {"ransac", "ransac-weighted", "loo", "lsq", "triplet", "mex-coarse", "ng-ransac",
                "learned"}
    trackers = set(list_trackers())
    for name, suite in L.SUITES.items():
        expected = builtins | trackers if suite.routes else builtins
        assert {e["name"].removesuffix(f"-{name}") for e in entries
                if e["suite"] == name} == expected, name
    shipped = "warehouse-small-simulated"  # the shipped log: its odometry and IMU drive trackers
    assert {e["name"].removesuffix(f"-data-{shipped}") for e in entries
            if e["suite"] == f"data:{shipped}"} == builtins | trackers


def test_the_committed_navigation_files_are_sound_and_complete():
    """Every navigation suite has a dev and a test file at full size, with both navigators on
    each of the suite's default localizers."""
    for name, suite in NAVIGATION_SUITES.items():
        for split in ("dev", "test"):
            data = load_navigation(NAVIGATION / f"{name}-{split}.json")
            assert (data["split"], data["quick"]) == (split, False)
            assert [(c["navigator"], c["localizer"]) for c in data["contenders"]] == \
                contenders_of(NAVIGATORS, suite.localizers)


# Tracks: a route suite's entry carries the figures of its tracks, checked like every other.

@pytest.fixture(scope="module")
def routes(tmp_path_factory):
    """route-events (809 frames, two routes, four events): lsq recovers from every event, dead
    reckoning (which never looks at a beacon after its start) from none."""
    out = tmp_path_factory.mktemp("routes")
    run_benchmark(get_suite("route-events"), [Contender("lsq", "lsq"), Contender(
        "dead-reckoning", "dead-reckoning")], quick=True).write(out, figures=False)
    return out


@pytest.fixture
def route_entry(routes, tmp_path):
    return L.submit(routes, "lsq", tmp_path / "entries", name="lsq-events", version="1",
                    authors=["a"])


def test_a_route_entry_carries_the_track_figures_of_its_run(routes, route_entry, entry_path):
    tracking = L.load_entry(route_entry)["metrics"]["tracking"]
    run = json.loads((routes / "results.json").read_text())["localizers"]["lsq"]["tracking"]
    assert tracking == clean(run)
    assert [event["event"] for event in tracking["events"]] == ["outage", "kidnap"] * 2
    assert all(event["recovery_s"] is not None for event in tracking["events"])
    assert L.load_entry(entry_path)["metrics"]["tracking"] is None  # stress: no sequences


def set_recovery(entry, seconds):
    entry["metrics"]["tracking"]["events"][1]["recovery_s"] = seconds


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda e: set_recovery(e, 0.1),
         r"metrics/tracking/events/1/recovery_s: the entry says 0.1, its per-frame results give "
         r"\d"),
        (lambda e: set_recovery(e, None),
         "metrics/tracking/events/1/recovery_s: the entry says None, its per-frame results give"),
        (lambda e: e["metrics"]["tracking"]["events"][1].update(event="outage"),
         "metrics/tracking/events/1/event: the entry says outage, its per-frame results give "
         "kidnap"),
        (lambda e: e["metrics"]["tracking"]["events"].pop(),
         "metrics/tracking/events: the entry says .*, its per-frame results give"),
        (lambda e: e["metrics"]["tracking"].update(availability_after_first_fix=1.0),
         "metrics/tracking/availability_after_first_fix: the entry says 1.0"),
        (lambda e: e["metrics"]["tracking"].update(frames_over_1m_outside_kidnaps=0),
         "metrics/tracking/frames_over_1m_outside_kidnaps: the entry says 0"),
        (lambda e: e["metrics"].update(tracking=None),
         r"metrics/tracking: the entry has None, its per-frame results give \['availability"),
        (lambda e: set_recovery(e, -1.0), "recovery_s: -1.0 is less than the minimum of 0"),
    ],
)
def test_a_forged_track_figure_is_refused_naming_it(route_entry, change, message):
    rewrite(route_entry, change)
    with pytest.raises(L.LeaderboardError, match=message):
        L.load_entry(route_entry)


def test_track_figures_claimed_on_a_suite_without_routes_are_refused(route_entry, entry_path):
    tracking = json.loads(route_entry.read_text())["metrics"]["tracking"]
    rewrite(entry_path, lambda e: e["metrics"].update(tracking=tracking))
    with pytest.raises(L.LeaderboardError, match=r"metrics/tracking: the entry says \{.*\}, its "
                       "per-frame results give None"):
        L.load_entry(entry_path)


def test_every_read_draws_a_suite_once_for_coverage_and_figures(entry_path, monkeypatch):
    stress, builds = get_suite("stress"), []

    def counted(seed, quick):
        builds.append(seed)
        return stress.build(seed, quick)

    # The draw the checks make: SUITES as checks.py reads it, with stress's build counted.
    monkeypatch.setattr(checks, "SUITES", {**L.SUITES, "stress": dataclasses.replace(
        stress, build=counted)})
    suite_cases.cache_clear()
    L.load_entry(entry_path)
    L.load_entry(entry_path)
    assert builds == [13]


def test_verify_compares_the_track_figures(route_entry):
    assert L.verify(route_entry) == {}
    claimed = {"tracking": {"events": [{"event": "kidnap", "recovery_s": 0.1}]}}
    fresh = {"tracking": {"events": [{"event": "kidnap", "recovery_s": 2.8}]}}
    assert L.differences(claimed, fresh, "") == {"tracking/events/0/recovery_s": (0.1, 2.8)}


def board_tables(readme):
    """Each table of a board's README: its title, header cells and rows' cells by name."""
    tables = {}
    for part in readme.read_text().split("\n## ")[1:]:
        suite = part.split(" — ")[0]
        lines = [line for line in part.splitlines() if line.startswith("| ")]
        header = [cell.strip() for cell in lines[0].split("|")[1:-1]]
        rows = {}
        for line in lines[1:]:
            cells = [cell.strip() for cell in line.split("|")[1:-1]]
            rows[cells[1]] = dict(zip(header, cells, strict=True))
        tables[suite] = (header, rows)
    return tables


def test_the_board_shows_track_columns_for_route_suites_only(routes, route_entry, results,
                                                              tmp_path):
    entries = route_entry.parent
    L.submit(routes, "dead-reckoning", entries, name="dr-events", version="1", authors=["a"])
    L.submit(results, "lsq", entries, name="lsq-stress", version="1", authors=["a"])
    run_benchmark(get_suite("warehouse-routes"), [Contender("lsq", "lsq")], quick=True).write(
        tmp_path / "plain", figures=False)
    L.submit(tmp_path / "plain", "lsq", entries, name="lsq-plain", version="1", authors=["a"])
    readme, page = B.build(entries, tmp_path / "board")
    tables = board_tables(readme)
    base = [c for c, _ in B.COLUMNS]
    assert tables["stress"][0] == base
    tracks = base[:B.TRACKS_AT] + list(B.TRACK_COLUMNS)
    assert tables["warehouse-routes"][0] == tracks + base[B.TRACKS_AT:]  # no events: no recovery
    header, rows = tables["route-events"]
    assert header == tracks + [B.RECOVERY_COLUMN] + base[B.TRACKS_AT:]
    tracking = L.load_entry(route_entry)["metrics"]["tracking"]
    lsq = rows["lsq-events"]
    assert lsq["track avail. %"] == f"{100 * tracking['availability_after_first_fix']:.1f}"
    assert lsq["track max cm"] == f"{tracking['max_cm_outside_kidnaps']:.1f}"
    assert lsq[B.RECOVERY_COLUMN] == f"{max(e['recovery_s'] for e in tracking['events']):.1f}"
    assert rows["dr-events"][B.RECOVERY_COLUMN] == "never (4/4)"
    assert "*track avail. %* is the share of frames" in readme.read_text()
    text = page.read_text()
    assert f"<th>{B.RECOVERY_COLUMN}</th>" in text and "<td>never (4/4)</td>" in text


@pytest.mark.slow
def test_the_recovery_column_sorts_never_after_every_time_in_headless_chromium(
        routes, route_entry, tmp_path):
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("Chromium is not installed (apt-get install chromium; .ci/run installs it)")
    L.submit(routes, "dead-reckoning", route_entry.parent, name="dr-events", version="1",
             authors=["a"])
    _, page = B.build(route_entry.parent, tmp_path / "board")
    probe = f"""<script>
      var table = document.querySelector("table.board"), cells = table.tHead.rows[0].cells;
      var column = Array.prototype.map.call(cells, function (c) {{ return c.textContent; }})
        .indexOf("{B.RECOVERY_COLUMN}");
      function values() {{
        return Array.prototype.map.call(table.tBodies[0].rows,
          function (row) {{ return row.cells[column].textContent; }}).join(";");
      }}
      cells[column].click(); var up = values(); cells[column].click(); var down = values();
      document.body.setAttribute("data-up", up); document.body.setAttribute("data-down", down);
    </script>"""
    harness = tmp_path / "harness.html"
    harness.write_text(page.read_text().replace("</body>", probe + "</body>"))
    attributes = body_attributes(chromium, harness, tmp_path)
    up = attributes["up"].split(";")
    assert up[-1] == "never (4/4)" and float(up[0]) >= 0
    assert attributes["down"].split(";") == up[::-1]


def test_a_test_split_entry_of_a_route_suite_is_refused(route_entry):
    # The same routes for every seed: its "test" frames would have the dev split's true poses.
    rewrite(route_entry, lambda e: e.update(split="test", seed=12345))
    with pytest.raises(L.LeaderboardError, match="route-events has no test split: its routes "
                                                 "are the same for every seed"):
        L.load_entry(route_entry)
