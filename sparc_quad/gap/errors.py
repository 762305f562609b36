"""The gap workflow's error types (a leaf module: every gap module may import it)."""

from __future__ import annotations

from pathlib import Path


class TrialError(ValueError):
    """Bad input. `file`, `row` (1-based data row, header excluded) and `column` say where."""

    def __init__(self, file: str | Path, message: str, row: int | None = None, column: str | None = None):
        self.file, self.row, self.column = str(file), row, column
        where = str(file)
        if row is not None:
            where += f", row {row} (line {row + 1})"
        if column is not None:
            where += f", column {column!r}"
        super().__init__(f"{where}: {message}")


class NumericalError(RuntimeError):
    """The input was accepted but a computation on it failed (e.g. a singular mass matrix): not bad input."""
