"""The VISA session: a resource manager for a backend, the instruments it finds, one opened.

The backend is whatever ``pyvisa.ResourceManager`` accepts, passed as given: ``@py``
(pyvisa-py: USBTMC through pyusb/libusb, TCPIP), ``@ivi`` (NI-VISA, TekVISA, Keysight) or
``devices.yaml@sim`` (pyvisa-sim, the simulated TDS2012 of ``motorid.io.sim``).  Every
failure a user meets (no backend, no instrument, no permission to open it, no answer)
becomes one :class:`~motorid.errors.InstrumentError` line saying what to do.
"""

from __future__ import annotations

import contextlib
import re
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from motorid.errors import AcquisitionTimeoutError, InstrumentError

__all__ = [
    "DEFAULT_VISA_LIBRARY",
    "FoundInstrument",
    "list_instruments",
    "no_instrument_error",
    "open_instrument",
    "resource_manager",
]

#: The backend used unless ``--visa-library`` names another: pyvisa-py, pure Python.
DEFAULT_VISA_LIBRARY = "@py"
#: Milliseconds a single VISA read or write may take (a 2500-point ASCII curve takes ~0.1 s).
IO_TIMEOUT_MS = 10_000
_PERMISSION = re.compile(r"access denied|insufficient permission|permission denied|errno 13|eacces", re.I)


def _access_hint() -> str:
    if sys.platform.startswith("linux"):
        return ("allow your user to open it: add the udev rule of docs/scope.md "
                "(SUBSYSTEM==\"usb\", ATTR{idVendor}==\"0699\", MODE=\"0666\"), then unplug and replug the scope")
    if sys.platform == "win32":
        return ("install NI-VISA (then --visa-library @ivi), or bind the scope to libusb with Zadig for the "
                "default @py backend (docs/scope.md)")
    return "install libusb (brew install libusb), or NI-VISA and --visa-library @ivi (docs/scope.md)"


def resource_manager(visa_library: str = DEFAULT_VISA_LIBRARY) -> Any:
    """A ``pyvisa.ResourceManager`` for the backend, or one line saying how to get one.

    Parameters
    ----------
    visa_library : str
        Passed to ``pyvisa.ResourceManager`` as is (``@py``, ``@ivi``, ``file.yaml@sim``, a path).

    Returns
    -------
    pyvisa.ResourceManager

    Raises
    ------
    InstrumentError
        pyvisa is not installed, or the backend cannot be loaded.
    """
    try:
        import pyvisa
    except ImportError:
        raise InstrumentError("pyvisa is not installed: pip install 'motorid[visa]' (pyvisa and its "
                              "pure-Python backend pyvisa-py)") from None
    try:
        return pyvisa.ResourceManager(visa_library)
    except (ValueError, OSError, pyvisa.errors.Error, ImportError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InstrumentError(f"no VISA backend for --visa-library {visa_library!r} ({first}): install pyvisa-py "
                              "(pip install 'motorid[visa]') for @py, or NI-VISA for @ivi") from None


def no_instrument_error(visa_library: str) -> InstrumentError:
    """The one-line error for a backend that finds no instrument, with the likely fix.

    Parameters
    ----------
    visa_library : str
        The backend searched.

    Returns
    -------
    InstrumentError
        Names PyUSB when pyvisa-py (``@py``) cannot reach USB at all, else the cable, the power
        and the platform's access rule.
    """
    import importlib.util

    if visa_library.strip().endswith("@py") and importlib.util.find_spec("usb") is None:
        return InstrumentError(f"no instrument found with --visa-library {visa_library}: pyvisa-py needs PyUSB to "
                               "reach a USB scope: pip install pyusb libusb-package, then run this again")
    return InstrumentError(f"no instrument found with --visa-library {visa_library}: connect the scope by USB (the "
                           f"USB port at its back) and switch it on; if it is connected, {_access_hint()}")


@dataclass(frozen=True, slots=True)
class FoundInstrument:
    """A resource the backend lists, with its ``*IDN?`` answer.

    Attributes
    ----------
    resource : str
        The VISA resource name (``USB0::0x0699::0x03A4::C010001::INSTR``).
    idn : str or None
        The ``*IDN?`` answer; ``None`` when it could not be asked.
    problem : str or None
        Why not (no permission, no answer).
    """

    resource: str
    idn: str | None
    problem: str | None = None


def _describe(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    if isinstance(exc, PermissionError) or _PERMISSION.search(text):
        return f"no permission to open it: {_access_hint()}"
    if "TMO" in text or "timeout" in text.lower():
        return "it did not answer *IDN? (switched off, or busy): check the cable and the scope"
    return text


def list_instruments(rm: Any, *, query: str = "?*::INSTR") -> tuple[FoundInstrument, ...]:
    """The instruments a backend finds, each asked ``*IDN?``.

    Parameters
    ----------
    rm : pyvisa.ResourceManager
        From :func:`resource_manager`.
    query : str
        VISA resource pattern (instruments by default; serial ports and sockets are left out).

    Returns
    -------
    tuple of FoundInstrument
        One per resource; an instrument that cannot be opened has ``problem`` set.

    Raises
    ------
    InstrumentError
        The backend cannot list resources at all.
    """
    import warnings

    import pyvisa

    try:
        with warnings.catch_warnings():
            # pyvisa-py warns that LAN (hislip) discovery needs zeroconf: not what a USB scope needs
            warnings.filterwarnings("ignore", category=UserWarning, module=r"pyvisa_py\..*")
            names = rm.list_resources(query)
    except pyvisa.errors.VisaIOError as exc:
        if exc.error_code != pyvisa.constants.StatusCode.error_resource_not_found:
            raise InstrumentError(f"the VISA backend cannot search for instruments ({_describe(exc)})") from None
        names = ()  # VISA's viFindRsrc reports "none found" as this error
    except Exception as exc:  # pyvisa backends raise their own types for a failed search
        raise InstrumentError(f"the VISA backend cannot search for instruments ({_describe(exc)})") from None
    found = []
    for name in names:
        try:
            with open_instrument(rm, name, timeout_ms=2000) as inst:
                found.append(FoundInstrument(name, inst.query("*IDN?").strip()))
        except InstrumentError as exc:
            found.append(FoundInstrument(name, None, exc.message))
        except Exception as exc:  # a backend's own error for one resource: shown, the others still listed
            found.append(FoundInstrument(name, None, _describe(exc)))
    return tuple(found)


@contextlib.contextmanager
def open_instrument(rm: Any, resource: str, *, timeout_ms: int = IO_TIMEOUT_MS) -> Iterator[Any]:
    """Open a resource with line-feed terminations; close it afterwards.

    Parameters
    ----------
    rm : pyvisa.ResourceManager
        From :func:`resource_manager`.
    resource : str
        The VISA resource name (``motorid scope list`` shows them).
    timeout_ms : int
        VISA I/O timeout.

    Yields
    ------
    pyvisa.resources.MessageBasedResource

    Raises
    ------
    InstrumentError
        No such instrument, no permission, or another VISA failure (while opening or using it).
    AcquisitionTimeoutError
        The instrument stopped answering (a VISA timeout while using it).
    """
    import pyvisa

    try:
        inst = rm.open_resource(resource)
    except Exception as exc:
        text = _describe(exc)
        missing = pyvisa.constants.StatusCode.error_resource_not_found
        if isinstance(exc, pyvisa.errors.VisaIOError) and exc.error_code == missing:
            text = "no such instrument: run 'motorid scope list' to see the connected ones"
        raise InstrumentError(f"cannot open {resource}: {text}") from None
    try:
        inst.timeout = timeout_ms
        inst.read_termination = "\n"
        inst.write_termination = "\n"
        yield inst
    except pyvisa.errors.VisaIOError as exc:
        if exc.error_code == pyvisa.constants.StatusCode.error_timeout:
            raise AcquisitionTimeoutError(f"{resource} did not answer within {timeout_ms / 1000:g} s: check the "
                                          "cable and that the scope is not showing a menu that blocks it; "
                                          "then acquire again") from None
        raise InstrumentError(f"{resource}: {_describe(exc)}") from None
    finally:
        with contextlib.suppress(Exception):
            inst.close()
