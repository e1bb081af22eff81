"""Capture-file readers and writers: Tektronix TDS1000/2000 CSV, OpenChoice ``.xlsx``, plain CSV.

Every reader returns a :class:`motorid.capture.Capture` (CH1 = step input, CH2 = measured
output, scope metadata in :class:`~motorid.capture.ChannelInfo`/:class:`~motorid.capture.ScopeInfo`)
and raises a :class:`~motorid.errors.MotorIdError` subclass naming the file and row for bad
input.  :func:`read_capture` picks the reader from the file's content.
"""

from motorid.io._common import check_writable
from motorid.io.atomic import OutputWriteError, atomic_folder, atomic_outputs
from motorid.io.detect import detect_format, read_capture
from motorid.io.plaincsv import read_plain_csv
from motorid.io.spreadsheet import read_xlsx_capture, write_openchoice_xlsx
from motorid.io.tektronix import (
    TdsChannel,
    read_tds_capture,
    read_tds_channel,
    write_tds_capture,
    write_tds_channel,
)

__all__ = [
    "OutputWriteError",
    "TdsChannel",
    "atomic_folder",
    "atomic_outputs",
    "check_writable",
    "detect_format",
    "read_capture",
    "read_plain_csv",
    "read_tds_capture",
    "read_tds_channel",
    "read_xlsx_capture",
    "write_openchoice_xlsx",
    "write_tds_capture",
    "write_tds_channel",
]
