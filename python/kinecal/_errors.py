"""Exceptions of kinecal (imported by the native module when it raises)."""


class KinecalError(Exception):
    """An error of kinecal; the message is the command line's one-line reason."""


class RefusedError(KinecalError, ValueError):
    """Input kinecal refuses (malformed, or implausible in the units assumed): the command
    line's exit status 2. The message names what to fix (and the unit to pass)."""


class NotConvergedWarning(UserWarning):
    """``identify`` (or ``diagnose``) did not converge: the numbers are not a calibration
    (the command line's exit status 3). ``result.converged`` is False."""


class DataWarning(UserWarning):
    """Something suspicious in the input that kinecal did not refuse (a unit, a table's
    knots, a reflector, a pace of time stamps …): the line the command line prints on stderr
    as ``warning: …`` (or ``note: …``), raised through Python's warnings machinery."""
