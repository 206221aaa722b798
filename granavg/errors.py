"""Errors a user can cause, and how the CLI reports them.

A :class:`UserError` is a mistake in the input (a bad setting, a truncated file, an
output directory that holds another run). The CLI prints its one-line message and exits
with code 2, without a traceback. Anything else is a bug and keeps its traceback.
"""


class UserError(Exception):
    """A user mistake: one line saying what, where and what to do. CLI exit code 2."""

    exit_code = 2


class ParameterError(UserError):
    """A user mistake about one parameter. The message names it ``{param}`` in its
    template, so that each front end names it its own way: the Python name by default
    (``t_min``), the CLI its option (``--t-min``, :meth:`named`).

    Parameters
    ----------
    param : str
        The parameter's Python name.
    template : str
        The message, with ``{param}`` where the parameter is named.
    """

    def __init__(self, param: str, template: str):
        self.param, self.template = param, template
        super().__init__(template.format(param=param))

    def named(self, names: dict) -> str:
        """The message with the parameter named as ``names`` says (else unchanged)."""
        return self.template.format(param=names.get(self.param, self.param))


class LammpsError(UserError):
    """LAMMPS stopped with an error (bad deck variable, lost atoms, blow-up)."""
