"""User-facing error types: all of them, in one place.

Every user mistake (a bad file, a bad option, data that cannot give a model) raises a
subclass of :class:`MotorIdError`.  The CLI turns these into one line on stderr and exit
code 2; any other exception is a bug (exit 1, traceback behind ``--debug``).  Each class is
also the matching built-in (``ValueError`` for bad values and data, ``FileExistsError`` and
``OSError`` for outputs), as python-control's ``ControlDimension(ValueError)``: a caller's
``except ValueError`` sees them.  The modules that raise them re-export them under their old
names (``motorid.model.ModelFormatError``, ``motorid.identification.result.IdentificationError``…).
"""

from __future__ import annotations

__all__ = [
    "AcquisitionTimeoutError",
    "CaptureDataError",
    "CaptureFormatError",
    "ChannelOffError",
    "ConditioningError",
    "ControlDesignError",
    "IdentificationError",
    "InstrumentError",
    "ModelFormatError",
    "MotorIdError",
    "OptionError",
    "OutputExistsError",
    "OutputWriteError",
    "ResponseNotStepError",
    "StepNotFoundError",
    "UploadError",
]


class MotorIdError(Exception):
    """Base class of every error caused by the user's input.

    Parameters
    ----------
    message : str
        What is wrong and, where possible, what would fix it.
    file : str, optional
        The file (or folder) the problem is in.
    row : int, optional
        1-based line/row number in ``file`` for parse errors.
    """

    def __init__(self, message: str, *, file: str | None = None, row: int | None = None) -> None:
        self.message = message
        self.file = None if file is None else str(file)
        self.row = row
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = ""
        if self.file is not None:
            where = self.file if self.row is None else f"{self.file}:{self.row}"
            where += ": "
        return f"{where}{self.message}"

    def with_file(self, file: str) -> MotorIdError:
        """Return a copy of this error that names ``file`` (if it names none yet).

        Parameters
        ----------
        file : str
            The file to name.

        Returns
        -------
        MotorIdError
            This error when it already names a file, else a copy naming ``file``.
        """
        if self.file is not None:
            return self
        return type(self)(self.message, file=file, row=self.row)


class CaptureFormatError(MotorIdError, ValueError):
    """The file is not a capture in any supported format, or it cannot be parsed."""


class CaptureDataError(MotorIdError, ValueError):
    """The file parses but its samples are unusable (NaN, bad time axis, mismatched channels)."""


class StepNotFoundError(MotorIdError, ValueError):
    """No usable step edge in the input channel (or in the response, without one)."""


class ResponseNotStepError(StepNotFoundError):
    """The input channel changes like a response (exponential rise), not like a step."""


class ConditioningError(MotorIdError, ValueError):
    """A conditioning step cannot be applied to these data with these settings."""


class OutputExistsError(MotorIdError, FileExistsError):
    """Refusing to overwrite an existing file without ``--force``."""


class OutputWriteError(MotorIdError, OSError):
    """An output file could not be written.

    Disk full, permissions, read-only file system, a path that is a device.
    """


class OptionError(MotorIdError, ValueError):
    """A command-line option or a function argument has an invalid value."""


class ControlDesignError(OptionError):
    """A controller or observer cannot be designed for this model with these settings."""


class ModelFormatError(MotorIdError, ValueError):
    """A model JSON file (or a model built by hand) is malformed."""


class IdentificationError(MotorIdError, ValueError):
    """The data cannot give a model with the requested method and settings.

    Raised, for example, when too few samples remain for the requested order or when the
    step response never rises; the message says what would fix it.
    """


# --- the local web page ---


class UploadError(MotorIdError, ValueError):
    """An upload the local web app refuses.

    Too large, too many files, a malformed form, an unsafe or broken ``.zip``, or a file of no
    supported kind.
    """


# --- live scope acquisition ---
class InstrumentError(MotorIdError, OSError):
    """The oscilloscope cannot be reached.

    No VISA backend, no instrument, no permission to open it, or it stopped answering.
    """


class AcquisitionTimeoutError(InstrumentError, TimeoutError):
    """The oscilloscope did not finish an acquisition (it never triggered) or did not answer in time."""


class ChannelOffError(MotorIdError, ValueError):
    """A channel asked for (``--channels``) is switched off on the oscilloscope."""
