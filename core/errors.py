"""The one exception type for errors the user can fix."""


class InputError(ValueError):
    """Bad input the user can fix (file, grid, load, mesh, unconverged step).

    The message is one line; the CLI prints it and exits non-zero without a traceback.
    """
