"""Error types shared by every stage.

The CLI maps them to exit codes: :class:`InputError` exits
with 2 (bad input or usage), :class:`StageError`
with 1 (valid input that a stage could not process).
"""


class InkrayError(Exception):
    """Base class of every error inkray raises on purpose."""

    exit_code = 1


class InputError(InkrayError, ValueError):
    """Bad input: the message names what is wrong and where (key path, pixel).

    Parameters
    ----------
    message : str
    option : str, optional
        The keyword parameter whose value is wrong, when the message starts
        with it as its key (``"size: ..."``).
    fix : (str, str), optional
        A remedy naming a parameter: a template with ``{}`` where the
        parameter goes, and the parameter (``("raise it with {}",
        "limits.pixels")``), appended in parentheses.

    Front ends name those parameters their own way (the command line as its
    flags) with :meth:`worded`; ``str()`` names them as the library does.

    Examples
    --------
    >>> e = InputError("size: give either a size or a width and height", option="size",
    ...                fix=("drop {}", "size"))
    >>> str(e)
    'size: give either a size or a width and height (drop size)'
    >>> e.worded(lambda name: "--" + name)
    '--size: give either a size or a width and height (drop --size)'
    """

    exit_code = 2

    def __init__(self, message, *, option=None, fix=None):
        super().__init__(message)
        self.message = message
        self.option = option
        self.fix = fix

    def worded(self, name):
        """The message with every parameter it names as ``name(parameter)``."""
        return _worded(self.message, self.option, self.fix, name)

    def __str__(self):
        return self.worded(lambda parameter: parameter)


class StageError(InkrayError, RuntimeError):
    """A stage failed on valid input."""

    exit_code = 1


class Notice(str):
    """A warning's text that names a parameter, worded by front ends as :class:`InputError` is.

    Examples
    --------
    >>> w = Notice("region 'a' must be split", fix=("{} splits it", "split_local"))
    >>> w, w.worded(lambda name: "--" + name.replace("_", "-"))
    ("region 'a' must be split (split_local splits it)", "region 'a' must be split (--split-local splits it)")
    """

    def __new__(cls, message, *, option=None, fix=None):
        self = super().__new__(cls, _worded(message, option, fix, lambda parameter: parameter))
        self.message, self.option, self.fix = message, option, fix
        return self

    def worded(self, name):
        """The text with every parameter it names as ``name(parameter)``."""
        return _worded(self.message, self.option, self.fix, name)


def _worded(message, option, fix, name):
    if option is not None and message.startswith(f"{option}:"):
        message = name(option) + message[len(option):]
    if fix is not None:
        template, parameter = fix
        message = f"{message} ({template.format(name(parameter))})"
    return message
