"""Error types shared by every stage.

The CLI maps them to exit codes: :class:`InputError` exits
with 2 (bad input or usage), :class:`StageError`
with 1 (valid input that a stage could not process).
"""


class InkrayError(Exception):
    """Base class of every error inkray raises on purpose."""

    exit_code = 1


class InputError(InkrayError, ValueError):
    """Bad input: the message names what is wrong and where (key path, pixel)."""

    exit_code = 2


class StageError(InkrayError, RuntimeError):
    """A stage failed on valid input."""

    exit_code = 1
