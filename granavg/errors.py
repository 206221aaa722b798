"""Errors a user can cause, and how the CLI reports them.

A :class:`UserError` is a mistake in the input (a bad setting, a truncated file, an
output directory that holds another run). The CLI prints its one-line message and exits
with code 2, without a traceback. Anything else is a bug and keeps its traceback.
"""


class UserError(Exception):
    """A user mistake: one line saying what, where and what to do. CLI exit code 2."""

    exit_code = 2


#: How the front end names parameters (the CLI: its options); Python names by default.
_naming = {"of": None}


def name_parameters(naming) -> None:
    """Let messages name parameters as the front end does: ``naming(python_name) ->
    text`` (the CLI sets its options' flags)."""
    _naming["of"] = naming


def literal(text) -> str:
    """Text (a path, a value) as a literal part of a message template: braces doubled."""
    return str(text).replace("{", "{{").replace("}", "}}")


def named(template: str) -> str:
    """``template`` with each ``{name}`` field a parameter named as the front end does
    (for log lines; errors carry their template: :meth:`ParameterError.named`)."""
    return _format(template, _naming["of"] or (lambda n: n), None)


def _format(template, lookup, param):
    try:
        return template.format_map(_Names(lookup, param))
    except (ValueError, IndexError, KeyError, AttributeError):       # braces in a value
        return template if param is None else template.replace("{param}", lookup(param))


class ParameterError(UserError):
    """A user mistake about parameters. The message names them as ``{name}`` fields of
    its template, so that each front end names them its own way: the Python name by
    default (``t_min``), the CLI its option (``--t-min``, :meth:`named`). ``{param}`` is
    the parameter the error is about; any other field names another parameter.

    Parameters
    ----------
    param : str
        The Python name of the parameter the error is about.
    template : str
        The message, with ``{param}`` (and ``{other_name}``) where parameters are named.
    """

    def __init__(self, param: str, template: str):
        self.param, self.template = param, template
        super().__init__(self.named({}))

    def named(self, names) -> str:
        """The message with each parameter named by ``names`` (a mapping or a function
        of the Python name; names it lacks stay Python names)."""
        lookup = names if callable(names) else (lambda n: names.get(n, n))
        return _format(self.template, lookup, self.param)


class _Names(dict):
    """``{param}`` and ``{name}`` fields of a template, named by ``lookup``."""

    def __init__(self, lookup, param):
        super().__init__()
        self.lookup, self.param = lookup, param

    def __missing__(self, key):
        return self.lookup(self.param if key == "param" else key)


class LammpsError(UserError):
    """LAMMPS stopped with an error (bad deck variable, lost atoms, blow-up)."""


def message(exc: UserError) -> str:
    """A user error's one line, its parameters named as the front end names them."""
    if isinstance(exc, ParameterError):
        return exc.named(_naming["of"] or (lambda n: n))
    return str(exc)
