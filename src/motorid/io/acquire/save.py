"""Save an acquisition as the scope's own "Save All" folder, ``ALLnnnn/FnnnnCH<n>.CSV``.

The files are written by :func:`motorid.io.tektronix.write_tds_channel`, the writer of the
demo's captures, so every command reads them as it reads a USB stick's files.  All channel
files appear together or none (:func:`motorid.io.atomic.atomic_outputs`).
"""

from __future__ import annotations

import contextlib
import re
from pathlib import Path

from motorid.errors import OptionError
from motorid.io._common import PathLike, check_writable
from motorid.io.acquire.scpi import Acquisition
from motorid.io.atomic import atomic_outputs
from motorid.io.tektronix import write_tds_channel

__all__ = ["channel_file", "save_acquisition", "save_all_folder"]

_ALL = re.compile(r"^ALL(\d{4})$", re.IGNORECASE)


def save_all_folder(out: PathLike) -> tuple[Path, int]:
    """The ``ALLnnnn`` folder to write and its number.

    Parameters
    ----------
    out : path
        Either an ``ALLnnnn`` folder (used as it is) or a folder to write the next free
        ``ALLnnnn`` into, as the scope numbers its saves on a USB stick.

    Returns
    -------
    (Path, int)
        The folder and ``nnnn``.

    Raises
    ------
    OptionError
        ``out`` is a file, or all of ``ALL0000`` … ``ALL9999`` exist.
    """
    p = Path(out)
    m = _ALL.match(p.name)
    if m:
        return p, int(m.group(1))
    if p.exists() and not p.is_dir():
        raise OptionError("is a file: give --out a folder (ALL0000, or a folder to number the saves in)", file=str(p))
    taken = {int(m.group(1)) for c in (p.iterdir() if p.is_dir() else ()) if (m := _ALL.match(c.name))}
    free = next((i for i in range(10_000) if i not in taken), None)
    if free is None:
        raise OptionError("holds ALL0000 … ALL9999 already: give --out another folder", file=str(p))
    return p / f"ALL{free:04d}", free


def channel_file(folder: Path, index: int, channel: int) -> Path:
    """``folder/FnnnnCH<n>.CSV``.

    Parameters
    ----------
    folder : Path
        The ``ALLnnnn`` folder.
    index : int
        ``nnnn``.
    channel : int
        1–4.

    Returns
    -------
    Path
    """
    return folder / f"F{index:04d}CH{channel}.CSV"


def save_acquisition(acquisition: Acquisition, out: PathLike, *, force: bool = False) -> Path:
    """Write every channel of an acquisition as ``ALLnnnn/FnnnnCH<n>.CSV``.

    Parameters
    ----------
    acquisition : Acquisition
        From :func:`motorid.io.acquire.acquire_waveforms`.
    out : path
        An ``ALLnnnn`` folder, or a folder to create the next free ``ALLnnnn`` in.
    force : bool
        Overwrite existing channel files.

    Returns
    -------
    Path
        The ``ALLnnnn`` folder.

    Raises
    ------
    OutputExistsError
        A channel file exists and ``force`` is false (nothing is written).
    OptionError
        The folder cannot be written.
    OutputWriteError
        Writing failed (disk full): no channel file was written.
    """
    folder, index = save_all_folder(out)
    targets = [channel_file(folder, index, w.channel) for w in acquisition.waveforms]
    check_writable(targets, force=force)
    created = not folder.exists()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptionError(f"cannot create the folder ({exc.strerror or exc})", file=str(folder)) from None
    try:
        with atomic_outputs() as outs:
            for target, wave in zip(targets, acquisition.waveforms, strict=True):
                write_tds_channel(outs.path(target), wave.time_s, wave.volts, wave.info, acquisition.scope,
                                  force=True)
    except BaseException:
        if created:
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise
    return folder
