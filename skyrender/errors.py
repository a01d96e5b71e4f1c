"""Errors that mean "the user gave us something we cannot use".

The command line turns an :class:`InputError` into a one-line message on
stderr and exit status 2 (README, Command line); everything else is a bug.
"""


class InputError(ValueError):
    """Bad input: a missing or unreadable file, a DEM that is not a DEM,
    a value out of range, a pose outside the DEM."""
