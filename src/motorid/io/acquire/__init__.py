"""Live acquisition from a Tektronix TDS1000/TDS2000/TBS1000 over VISA (USBTMC or LAN).

Open a backend (:func:`resource_manager`: pyvisa-py ``@py`` by default), find the scope
(:func:`list_instruments`), open it (:func:`open_instrument`), acquire its channels
(:func:`acquire_waveforms`) and save them in the scope's own "Save All" layout
(:func:`save_acquisition`), which every reader of :mod:`motorid.io` accepts::

    from motorid.io.acquire import (AcquireSettings, acquire_waveforms, open_instrument,
                                    resource_manager, save_acquisition)

    rm = resource_manager("@py")
    with open_instrument(rm, "USB0::0x0699::0x03A4::C010001::INSTR") as scope:
        acq = acquire_waveforms(scope, AcquireSettings(channels=(1, 2), single=True))
    folder = save_acquisition(acq, "captures")        # captures/ALL0000/F0000CH1.CSV, …

Needs the ``visa`` extra (``pip install 'motorid[visa]'``); importing this package does not.
"""

from motorid.io.acquire.curve import clipping_warning, decode_ascii_curve, decode_binary_curve
from motorid.io.acquire.preamble import PREAMBLE_FIELDS, Preamble, parse_field, query_preamble
from motorid.io.acquire.save import channel_file, save_acquisition, save_all_folder
from motorid.io.acquire.scpi import (
    ENCODINGS,
    RECORD_POINTS,
    AcquireSettings,
    Acquisition,
    Identity,
    Waveform,
    acquire_waveforms,
    parse_idn,
)
from motorid.io.acquire.visa import (
    DEFAULT_VISA_LIBRARY,
    FoundInstrument,
    list_instruments,
    open_instrument,
    resource_manager,
)

__all__ = [
    "DEFAULT_VISA_LIBRARY",
    "ENCODINGS",
    "PREAMBLE_FIELDS",
    "RECORD_POINTS",
    "AcquireSettings",
    "Acquisition",
    "FoundInstrument",
    "Identity",
    "Preamble",
    "Waveform",
    "acquire_waveforms",
    "channel_file",
    "clipping_warning",
    "decode_ascii_curve",
    "decode_binary_curve",
    "list_instruments",
    "open_instrument",
    "parse_field",
    "parse_idn",
    "query_preamble",
    "resource_manager",
    "save_acquisition",
    "save_all_folder",
]
