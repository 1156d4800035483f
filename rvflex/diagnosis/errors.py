"""The diagnosis's exception for bad bench input (shared by the reader and the feature fits)."""

from __future__ import annotations

__all__ = ["BenchError"]


class BenchError(ValueError):
    """Bad bench input: ``where`` names the file (and row or key), ``problem`` says what is wrong."""

    def __init__(self, where: str, problem: str):
        self.where, self.problem = where, problem
        super().__init__(f"{where}: {problem}")

    def __reduce__(self):
        return (type(self), (self.where, self.problem))
