"""Errors calib-pin raises for a user's mistake.

Every error a user can cause (a bad file, an unknown robot, a wrong option) is a
:class:`CalibPinError`. The command line prints its one-line message and exits with
status 2; library callers catch it like any exception.
"""

from __future__ import annotations

import os


class CalibPinError(Exception):
    """Base class of the errors calib-pin raises for bad input."""


class RobotError(CalibPinError):
    """A robot that cannot be loaded or has no model for what was asked."""


class DataError(CalibPinError):
    """A measurement file with a problem, located by file, line and field.

    Attributes:
        path: File that holds the problem.
        line: 1-based line number in that file, or None for the file as a whole.
        field: Column or metadata key at fault, or None.
        reason: What is wrong, in words.
    """

    def __init__(
        self, path: str | os.PathLike[str], reason: str, line: int | None = None, field: str | None = None
    ) -> None:
        self.path = str(path)
        self.line = line
        self.field = field
        self.reason = reason
        where = self.path if line is None else f"{self.path}:{line}"
        what = f" {field}:" if field else ""
        super().__init__(f"{where}:{what} {reason}")


class ArgumentError(CalibPinError):
    """A library function's argument of the wrong type, shape, unit or value.

    Attributes:
        argument: The argument's name, as the function's signature spells it.
        reason: What is wrong, in words.
    """

    def __init__(self, argument: str, reason: str) -> None:
        self.argument = argument
        self.reason = reason
        super().__init__(f"argument {argument}: {reason}")


class EstimatorError(CalibPinError):
    """An unknown estimator name or an estimate that cannot be made."""
