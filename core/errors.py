"""The one exception type for errors the user can fix."""


class InputError(ValueError):
    """Bad input the user can fix (file, grid, load, mesh, unconverged step).

    The message is one line; the CLI prints it and exits non-zero without a traceback.
    """


class ConvergenceError(InputError):
    """A FEM run that did not converge (its partial results are written, labelled).

    A subclass of InputError, so callers that stop on any refusal still do; the CLI exits with
    its own status (``EXIT_NOT_CONVERGED``).
    """
