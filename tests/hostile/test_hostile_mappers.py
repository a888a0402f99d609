"""A hostile mapper plug-in answering garbage: azgym's check refuses each kind by name.

The plug-in builds its garbage two ways: through :class:`MapAnswer` (whose own checks refuse it
inside the plug-in's call) and around those checks (``object.__new__`` and
``object.__setattr__``, or a subclass that skips them), which :func:`check_mapper` must catch
by checking every answer again. Each check runs in a child process, bounded by a timeout and an
address-space limit, so a regression that hangs or hoards fails the test instead of the run.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

MEMORY = 2048 * 2**20
"""The child's address-space limit [bytes]: a million smuggled beacons fit, a copy per check of
them many times over does not."""
CHILD = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({memory}, {memory}))
from azgym.cli import main
sys.exit(main(["check", sys.argv[1]]))
"""
PLUGIN = textwrap.dedent('''
    """Mappers that answer garbage."""

    import itertools

    import numpy as np

    from azgym.mapping import MapAnswer


    def smuggled(**fields):
        """A MapAnswer made around its checks."""
        answer = object.__new__(MapAnswer)
        for name, value in fields.items():
            object.__setattr__(answer, name, value)
        return answer


    def good(n=1):
        return dict(ids=np.arange(3, 3 + n), xy=np.tile([[3.0, 3.0]], (n, 1)),
                    covariances=np.tile(np.eye(2) * 1e-4, (n, 1, 1)), moved=())


    class Base:
        def survey(self, drive, prior):
            if not drive.frames:
                raise ValueError("empty")
            return self.answer()


    class NotAnAnswer(Base):
        def answer(self):
            return {"ids": [3], "xy": [[3.0, 3.0]]}


    class WrongShape(Base):
        def answer(self):
            return smuggled(**{**good(), "xy": np.zeros((1, 3))})


    class NaN(Base):
        def answer(self):
            return smuggled(**{**good(), "xy": np.array([[np.nan, 3.0]])})


    class NotPositiveDefinite(Base):
        def answer(self):
            return smuggled(**{**good(), "covariances": np.array([[[1.0, 2.0], [2.0, 1.0]]])})


    class MillionBeacons(Base):
        def answer(self):
            return smuggled(**good(1_000_000))


    class EndlessMoved(Base):
        def answer(self):
            return smuggled(**{**good(), "moved": itertools.count()})


    class Unchecked(MapAnswer):
        def __post_init__(self):
            pass


    class SubclassSkipsItsChecks(Base):
        def answer(self):
            return Unchecked(np.array([3]), np.array([[np.inf, 0.0]]), np.eye(2)[None])


    class RefusedByMapAnswer(Base):
        def answer(self):
            return MapAnswer(np.array([3, 3]), np.zeros((2, 2)), np.tile(np.eye(2), (2, 1, 1)))
''')


@pytest.mark.parametrize(("name", "problem"), [
    ("NotAnAnswer", "a mapper must answer a MapAnswer, got dict"),
    ("WrongShape", "MapAnswer.xy must have shape (1, 2), got (1, 3)"),
    ("NaN", "MapAnswer.xy holds a NaN or infinite position"),
    ("NotPositiveDefinite", "MapAnswer.covariances must be positive definite"),
    ("MillionBeacons", "MapAnswer.ids must be a 1-D array of at most 100000 integers"),
    ("EndlessMoved", "MapAnswer.moved must be a tuple of at most 100000 ids, got a count"),
    ("SubclassSkipsItsChecks", "MapAnswer.xy holds a NaN or infinite position"),
    ("RefusedByMapAnswer", "MapAnswer.ids repeat an id"),
])
def test_azgym_check_refuses_a_garbage_answer_by_name(tmp_path, name, problem):
    path = tmp_path / "garbage_mapper.py"
    path.write_text(PLUGIN)
    done = subprocess.run([sys.executable, "-c", CHILD.format(memory=MEMORY), f"{path}:{name}"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr[-2000:]
    assert "Traceback" not in done.stderr
    expected = ("check_mapper: a MapAnswer for the map unknown but for two anchors: "
                f"InvalidInputError: {problem}")
    assert expected in done.stderr, done.stderr[-2000:]
