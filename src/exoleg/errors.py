"""Exceptions raised by exoleg. Every message names what was wrong and what is allowed."""

from __future__ import annotations


class ExolegError(Exception):
    """Base class of every error exoleg raises on purpose."""


class ParameterError(ExolegError, ValueError):
    """A parameter (from a file, a record or an argument) is missing or invalid.

    Parameters
    ----------
    where : str
        The file or record.
    field : str
        The offending field.
    problem : str
        What is wrong and what is allowed.
    """

    def __init__(self, where: str, field: str, problem: str) -> None:
        self.where = where
        self.field = field
        self.problem = problem
        super().__init__(f"{where}: {field}: {problem}")

    def __reduce__(self) -> tuple[type, tuple[str, str, str]]:
        # crosses processes whole (a study's worker, a pool): pickled by its three parts
        return (type(self), (self.where, self.field, self.problem))


class UnreachableError(ExolegError, ValueError):
    """An inverse-kinematics target lies outside the leg's workspace."""


class SimulationError(ExolegError, RuntimeError):
    """A simulation could not go on (e.g. a non-finite state)."""
