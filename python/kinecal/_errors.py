"""Exceptions of kinecal (imported by the native module when it raises)."""


class KinecalError(Exception):
    """An error of kinecal; the message is the command line's one-line reason."""


class RefusedError(KinecalError, ValueError):
    """Input kinecal refuses (malformed, or implausible in the units assumed): the command
    line's exit status 2. The message names what to fix (and the unit to pass)."""


class NotConvergedWarning(UserWarning):
    """An outcome the command line reports with exit status 3: ``identify`` (or ``diagnose``)
    did not converge, so the numbers are not a calibration; or ``compensate`` did not reach
    every target, so the failed rows' commands must not be sent. The result is returned, as
    the command line writes its output, with ``result.converged`` False; the message is the
    command line's error. ``warnings.simplefilter("error", NotConvergedWarning)`` makes it an
    exception."""


class DataWarning(UserWarning):
    """Something suspicious in the input that kinecal did not refuse (a unit, a table's
    knots, a reflector, a pace of time stamps …): the line the command line prints on stderr
    as ``warning: …`` (or ``note: …``), raised through Python's warnings machinery."""
