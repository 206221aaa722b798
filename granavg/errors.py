"""Errors a user can cause, and how the CLI reports them.

A :class:`UserError` is a mistake in the input (a bad setting, a truncated file, an
output directory that holds another run). The CLI prints its one-line message and exits
with code 2, without a traceback. Anything else is a bug and keeps its traceback.
"""


class UserError(Exception):
    """A user mistake: one line saying what, where and what to do. CLI exit code 2."""

    exit_code = 2


class LammpsError(UserError):
    """LAMMPS stopped with an error (bad deck variable, lost atoms, blow-up)."""
