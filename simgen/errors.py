"""The one exception type for bad user input (config, files, arguments).

The CLI turns it into a single line on stderr and exit code 2, with no traceback.
"""


class UserError(Exception):
    """Bad input from the user: the message names the problem in one line."""
