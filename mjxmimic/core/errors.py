"""The one exception type that the command line turns into a one-line error."""


class UserError(Exception):
    """Bad input from a person (a file, a config key, a run folder): the message names it."""
