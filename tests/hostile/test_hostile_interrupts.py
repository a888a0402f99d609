"""Ctrl-C and a finished run: a command interrupted ends with one line saying what it kept
and exit code 130, never a traceback; ``train localizer`` refuses to silently "resume" a run
that has finished."""

from __future__ import annotations

import argparse
import os
import selectors
import signal
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest

from azgym import cli
from azgym.cli.options import on_ctrl_c


@pytest.fixture
def ctrl_c_not_ignored() -> Iterator[None]:
    """Children started meanwhile take Ctrl-C, as a command run from a terminal does.

    A shell without job control starts its background commands with SIGINT ignored (so is a
    test run from a script with ``&``), and a child inherits that: it would take no Ctrl-C at
    all. A signal with a handler is reset to its default in a child, so the test process handles
    SIGINT while it starts one.
    """
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


@pytest.mark.slow
@pytest.mark.usefixtures("ctrl_c_not_ignored")
def test_ctrl_c_ends_a_command_with_one_line_and_exit_code_130(tmp_path):
    command = [sys.executable, "-m", "azgym", "evaluate", "navigator", "pure-pursuit",
               "--episodes", "100000", "--out", str(tmp_path / "out")]
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        with selectors.DefaultSelector() as waiting:  # its first line of progress: it is driving
            waiting.register(child.stderr, selectors.EVENT_READ)  # type: ignore[arg-type]
            assert waiting.select(timeout=90), "no progress within 90 s"
        first = child.stderr.readline()  # type: ignore[union-attr]
        time.sleep(0.5)
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=60)
    finally:
        child.kill()
    assert "episodes" in first
    assert child.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert err.strip().splitlines()[-1] == "azgym: interrupted"
    assert not (tmp_path / "out" / "navigation.json").exists()


def _run_instead(monkeypatch, handler):
    """Make every command line run ``handler`` (the command's own work replaced)."""
    class Parser:
        def parse_args(self, argv):
            return argparse.Namespace(handler=handler)
    monkeypatch.setattr(cli, "build_parser", Parser)


def _raise_from_a_kernel(args):
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as interruption:  # as numba's dispatcher wraps it
        raise SystemError("CPUDispatcher(gather) returned a result with an exception set") \
            from interruption


def test_ctrl_c_inside_a_compiled_kernel_is_still_an_interruption(monkeypatch, capsys):
    """A Ctrl-C landing in numba's machinery arrives as a SystemError raised from it."""
    _run_instead(monkeypatch, _raise_from_a_kernel)
    assert cli.main(["suites"]) == 130
    assert capsys.readouterr().err.strip() == "azgym: interrupted"


def test_a_command_that_keeps_something_says_what_also_when_a_kernel_wrapped_the_ctrl_c(
        monkeypatch, capsys):
    _run_instead(monkeypatch, lambda args: on_ctrl_c(lambda: _raise_from_a_kernel(args),
                                                     lambda: "its checkpoints are kept"))
    assert cli.main(["suites"]) == 130
    assert capsys.readouterr().err.strip() == "azgym: interrupted; its checkpoints are kept"


def test_a_system_error_not_from_ctrl_c_is_not_called_an_interruption(monkeypatch):
    def broken(args):
        raise SystemError("a genuine fault")
    _run_instead(monkeypatch, broken)
    with pytest.raises(SystemError, match="a genuine fault"):
        cli.main(["suites"])
    _run_instead(monkeypatch, lambda args: on_ctrl_c(lambda: broken(args), lambda: "kept"))
    with pytest.raises(SystemError, match="a genuine fault"):
        cli.main(["suites"])


class _FreedOnCtrlC:
    """An object whose finalizer a Ctrl-C lands in."""

    def __del__(self):
        raise KeyboardInterrupt


def _ctrl_c_in_a_finalizer() -> None:
    _FreedOnCtrlC()  # freed at once; its finalizer's exception is "ignored" by Python


def _ctrl_c_in_a_cffi_callback() -> None:
    """As pymunk frees a space: cffi's ``ffi.gc`` callback, its exception "ignored"."""
    import cffi

    def free(pointer):
        raise KeyboardInterrupt
    ffi = cffi.FFI()
    ffi.gc(ffi.new("int *"), free)


@pytest.mark.usefixtures("ctrl_c_not_ignored")
@pytest.mark.parametrize("lose_a_ctrl_c", [_ctrl_c_in_a_finalizer, _ctrl_c_in_a_cffi_callback])
def test_a_ctrl_c_that_lands_in_a_finalizer_still_stops_the_command(lose_a_ctrl_c, monkeypatch,
                                                                    capsys):
    """Python drops an exception raised in a finalizer: the Ctrl-C is delivered again."""
    carried_on = []

    def drive(args):
        lose_a_ctrl_c()
        for _ in range(200):  # the command's own work goes on: 2 s
            time.sleep(0.01)
        carried_on.append(True)
        return 0
    _run_instead(monkeypatch, drive)
    assert cli.main(["suites"]) == 130
    assert not carried_on
    err = capsys.readouterr().err
    assert err.strip() == "azgym: interrupted" and "KeyboardInterrupt" not in err


def test_another_exception_in_a_finalizer_still_reaches_the_hook_before(monkeypatch):
    seen = []
    monkeypatch.setattr(sys, "unraisablehook", lambda unraisable: seen.append(unraisable))

    class Broken:
        def __del__(self):
            raise ValueError("a genuine fault in a finalizer")

    def drive(args):
        Broken()
        return 0
    _run_instead(monkeypatch, drive)
    assert cli.main(["suites"]) == 0
    assert [str(unraisable.exc_value) for unraisable in seen] == ["a genuine fault in a finalizer"]
    assert sys.unraisablehook is not None and sys.unraisablehook.__name__ == "<lambda>"


@pytest.mark.parametrize("model,weights", [("ng-ransac", "ng-ransac.npz"),
                                           ("learned", "learned.npz")])
def test_a_finished_training_run_is_refused_unless_resumed_or_overwritten(model, weights,
                                                                           tmp_path, capsys):
    pytest.importorskip("torch", reason="training needs pip install torch==2.13.0")
    (tmp_path / weights).write_bytes(b"a finished run")
    (tmp_path / "checkpoint.pt").write_bytes(b"its checkpoint")
    assert cli.main(["train", "localizer", "--model", model, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"--out: {tmp_path} holds a finished run ({weights}, checkpoint.pt); nothing was " \
           "written (--resume trains on from its checkpoint" in err and "--overwrite" in err
    assert (tmp_path / "checkpoint.pt").read_bytes() == b"its checkpoint"
    with pytest.raises(SystemExit):
        cli.main(["train", "localizer", "--model", model, "--out", str(tmp_path), "--resume",
                  "--overwrite"])
    assert "not allowed with argument" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.usefixtures("ctrl_c_not_ignored")
def test_ctrl_c_in_a_bench_run_stops_its_workers_too_and_says_nothing_was_written(tmp_path):
    """A terminal sends Ctrl-C to the whole process group: the workers must not print either."""
    command = [sys.executable, "-m", "azgym", "bench", "--suite", "stress", "--localizer",
               "mex", "--workers", "2", "--out", str(tmp_path / "out")]
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env={**os.environ, "PYTHONUNBUFFERED": "1"},
                             start_new_session=True)
    try:
        with selectors.DefaultSelector() as waiting:  # its first count: the workers are busy
            waiting.register(child.stderr, selectors.EVENT_READ)  # type: ignore[arg-type]
            assert waiting.select(timeout=120), "no progress within 120 s"
        child.stderr.readline()  # type: ignore[union-attr]
        os.killpg(child.pid, signal.SIGINT)
        _, err = child.communicate(timeout=60)
    finally:
        child.kill()
    assert child.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert err.strip().splitlines()[-1] == ("azgym: interrupted; nothing was written: a run "
                                            "writes its results when it ends")
    assert not (tmp_path / "out" / "results.json").exists()
