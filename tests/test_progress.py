"""azgym.progress: one helper shows every command's progress. When piped, a count writes a
plain line at least every EVERY seconds (and one at the end) with done/total, the rate and the
time left; in a terminal its bar is redrawn in place and leaves no character behind; a plain
callback still hears the count as text redrawn in place."""

from __future__ import annotations

import io
import re

from azgym.progress import EVERY, Meter, counter


class FakeClock:
    """Seconds that move only when told."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class FakeTerminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self) -> bool:
        return True


def screen(written: str) -> list[str]:
    """What a terminal shows after ``written``: a carriage return goes back to the start of
    the line and overwrites; any other control character fails the test."""
    rows, row, column = [], [], 0
    for char in written:
        if char == "\n":
            rows.append("".join(row))
            row, column = [], 0
        elif char == "\r":
            column = 0
        else:
            assert char.isprintable(), f"unexpected control character {char!r}"
            row[column:column + 1] = [char]
            column += 1
    return [line.rstrip() for line in [*rows, "".join(row)]]


def test_a_piped_count_writes_a_line_at_least_every_few_seconds_with_rate_and_eta():
    clock, out = FakeClock(), io.StringIO()
    meter = Meter(out, out, terminal=False, clock=clock, ticking=False)
    with counter(meter, "ransac", 10) as count:
        for done in range(1, 11):  # a slow job: 12 s a frame, its count moving rarely
            for _ in range(12):
                clock.now += 1.0
                count.tick()  # type: ignore[attr-defined]  # what the meter's thread does
            count(done)
    lines = out.getvalue().splitlines()
    assert len(lines) >= 120 / EVERY
    assert lines[-1].startswith("  ransac: 10/10 frames [02:00<00:00,")
    assert all(re.fullmatch(r"  ransac: \d+/10 frames \[\d\d:\d\d<(\d\d:\d\d|\?), "
                            r"(\?|[\d.]+)(frames/s|s/frames)\]", line) for line in lines), lines
    assert "  ransac: 1/10 frames [00:16<02:24, 16.00s/frames]" in lines  # the time left


def test_a_count_in_a_terminal_is_redrawn_in_place_and_leaves_nothing_behind():
    terminal = FakeTerminal()
    meter = Meter(terminal, terminal, ticking=False)
    meter("compiling azgym's kernels")
    for label, took in (("a-localizer-with-a-long-label", 12.5), ("lsq", 0.4)):
        with counter(meter, label, 40) as count:
            for done in range(41):
                count(done)
                if done == 20:
                    meter("note: a line in the middle of a count")
        meter(f"  {label:<20} {took:6.1f} s")
    assert "%|" in terminal.getvalue()  # a bar was drawn
    assert [line for line in screen(terminal.getvalue()) if line] == [
        "compiling azgym's kernels", "note: a line in the middle of a count",
        "  a-localizer-with-a-long-label   12.5 s", "note: a line in the middle of a count",
        "  lsq                     0.4 s"]


def test_a_plain_callback_still_hears_a_count_redrawn_as_text():
    heard: list[str] = []
    with counter(heard.append, "ransac", 4) as count:
        for done in (0, 2, 2, 4):
            count(done)
    assert heard == ["\r  ransac               [....................] 0/4",
                     "\r  ransac               [##########..........] 2/4",
                     "\r  ransac               [####################] 4/4"]
