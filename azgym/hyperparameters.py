"""Hyperparameters, the scikit-learn way: keyword-only, stored as given, checked when set.

Localizers and trackers share this rule. A class takes its hyperparameters as keyword-only
``__init__`` arguments and stores them unchanged, so ``get_params()`` shows them and ``repr``
reproduces them. They are checked in ``__init__`` (a bad value fails where it is written, naming
the field) and, if one was set afterwards, again before the next use, with
:func:`check_range` for numbers and :func:`check_flag` for flags.
"""

from __future__ import annotations

import functools
from typing import Any

from azgym.fields import Flag, Number, argument_error, require
from azgym.registry import hyperparameter_names

__all__ = ["Hyperparameters", "check_flag", "check_range"]


class Hyperparameters:
    """Keyword-only hyperparameters with ``get_params``, ``repr`` and checking on change.

    Subclasses override ``_check_params`` and call ``_validate_once`` at the end of ``__init__``
    and before each use.
    """

    def _check_params(self) -> None:  # noqa: B027 - optional hook, no parameters by default
        """Raise :class:`InvalidInputError` naming any hyperparameter that is out of range."""

    def __setattr__(self, name: str, value: Any) -> None:
        """Set an attribute; setting a hyperparameter has it checked again before the next frame."""
        object.__setattr__(self, name, value)
        # A private attribute (a tracker's state, set every frame) is never a hyperparameter.
        # mypy#11470: mypy takes no class object for Hashable, which every class is.
        if not name.startswith("_") and name in _param_names(type(self)):  # type: ignore[arg-type]
            object.__setattr__(self, "_params_checked", False)

    def _take(self, arguments: dict[str, Any]) -> None:
        """Store each hyperparameter as given, from ``__init__``'s ``locals()``, and check them.

        For a class whose long argument list would otherwise be written out twice.
        """
        for name in _param_names(type(self)):  # type: ignore[arg-type]  # mypy#11470
            setattr(self, name, arguments[name])
        self._validate_once()

    def _validate_once(self) -> None:
        """Run ``_check_params`` unless it passed and no hyperparameter was set since.

        Hyperparameters set after construction are noticed by ``__setattr__``, so a frame costs
        one dictionary look-up here, not a comparison of every value.
        """
        if not self.__dict__.get("_params_checked", False):
            self._check_params()
            object.__setattr__(self, "_params_checked", True)

    def get_params(self) -> dict[str, Any]:
        """The hyperparameters, as given to ``__init__``."""
        names = _param_names(type(self))  # type: ignore[arg-type]  # mypy#11470, as above
        return {name: getattr(self, name) for name in names}

    def __repr__(self) -> str:
        params = ", ".join(f"{key}={value!r}" for key, value in self.get_params().items())
        return f"{type(self).__name__}({params})"


@functools.cache
def _param_names(cls: type[Hyperparameters]) -> tuple[str, ...]:
    """Names of the keyword-only ``__init__`` arguments of a class (remembered per class)."""
    return hyperparameter_names(cls)


def check_range(
    owner: str,
    name: str,
    value: Any,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    integer: bool = False,
    infinite: bool = False,
) -> None:
    """Raise :class:`InvalidInputError` unless ``value`` is a finite number in the given range.

    The rule is a :class:`azgym.fields.Number` (``integer``: an integer; ``infinite``: +inf
    accepted too, a gate that refuses nothing, say), its problem worded after
    ``<owner>.<name>``: ``Ransac.pr_hit must be in (0, 1), got 2``.
    """
    rule = Number(low, high, low_open, high_open, integer=integer, infinite=infinite)
    require(value, rule, functools.partial(argument_error, f"{owner}.{name}"))


_FLAG = Flag(python=True)


def check_flag(owner: str, name: str, value: Any) -> None:
    """Raise :class:`InvalidInputError` unless ``value`` is a bool (``"no"`` is not False).

    NumPy's bool is one too; the problem is worded ``<owner>.<name> must be True or False, ...``.
    """
    require(value, _FLAG, functools.partial(argument_error, f"{owner}.{name}"))
