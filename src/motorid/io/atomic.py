"""Atomic outputs: a command's files appear together when it succeeds, or not at all.

Every output of a command is first written to a temporary file in the target's own folder
(same file system, so the final rename is atomic) and renamed over the target only when the
whole command has succeeded.  On any failure — a bad ``--validate`` capture found after the
model JSON was rendered, a full disk half-way through a report, Ctrl-C — the temporary files
are removed and the targets are untouched.

Two helpers:

- :func:`atomic_outputs` for commands that write named files (``--json``, ``--report``,
  ``--png``): write through :meth:`AtomicOutputs.write_text` or into
  :meth:`AtomicOutputs.path`; everything is committed when the ``with`` block ends normally.
- :func:`atomic_folder` for commands that fill a folder with many files (``demo --out``):
  existing targets are moved aside first, and on failure whatever was created is removed and
  the old targets are put back.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from motorid.errors import MotorIdError, OutputWriteError
from motorid.options import switch_words

__all__ = ["AtomicOutputs", "OutputWriteError", "atomic_folder", "atomic_outputs"]


# OutputWriteError lives in motorid.errors with every other user-facing error


def _reason(exc: OSError) -> str:
    if exc.errno == errno.ENOSPC:
        return "the disk is full"
    if exc.errno == errno.EDQUOT:
        return "the disk quota is exceeded"
    if exc.errno in (errno.EACCES, errno.EPERM):
        return "permission denied"
    if exc.errno == errno.EROFS:
        return "the file system is read-only"
    return (exc.strerror or type(exc).__name__).rstrip(".").lower()


def write_error(target: Path | str, exc: OSError) -> OutputWriteError:
    """The one-line error for an ``OSError`` met while writing ``target``."""
    return OutputWriteError(f"cannot write the output ({_reason(exc)}); nothing was written: free space "
                            "or choose another folder", file=str(target))


def refuse_special(target: Path | str) -> None:
    """Refuse an output path that exists and is not a regular file (a device, a FIFO, a socket).

    The rename at commit would replace it — as root, ``--json /dev/full --force`` turned the device
    node into a regular file.

    Raises
    ------
    OutputWriteError
        Naming the path and what it is.
    """
    import stat

    try:
        mode = os.stat(target).st_mode
    except OSError:
        return  # does not exist (yet): a new file
    if stat.S_ISDIR(mode):
        return  # a folder is refused by check_writable with its own message
    if not stat.S_ISREG(mode):
        kind = ("a character device" if stat.S_ISCHR(mode) else "a block device" if stat.S_ISBLK(mode)
                else "a named pipe (FIFO)" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode)
                else "not a regular file")
        raise OutputWriteError(f"is {kind}, not a file: give the output a regular file path", file=str(target))


def _final_mode(target: Path) -> int:
    """Permissions the committed file gets: the old file's, else the umask's default."""
    try:
        return target.stat().st_mode & 0o7777
    except OSError:
        mask = os.umask(0)
        os.umask(mask)
        return 0o666 & ~mask


class AtomicOutputs:
    """The pending outputs of one command (see :func:`atomic_outputs`).

    Targets are checked before the work by :func:`motorid.io.check_writable`; this class only
    makes the writing itself all-or-nothing.
    """

    __slots__ = ("_exclusive", "_pending")

    def __init__(self, *, exclusive: bool = False) -> None:
        self._pending: dict[Path, Path] = {}  # target -> temporary file beside it
        self._exclusive = exclusive

    def path(self, target: Path | str) -> Path:
        """A temporary path beside ``target`` to write into.

        Same suffix, so writers that pick a format from the suffix — matplotlib — write the right
        one.

        Parameters
        ----------
        target : Path or str
            The final output path.

        Returns
        -------
        Path
            The temporary path; it becomes ``target`` at commit.

        Raises
        ------
        OutputWriteError
            The temporary file cannot be created in the target's folder.
        """
        target = Path(target)
        if target in self._pending:
            return self._pending[target]
        refuse_special(target)
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".part{target.suffix}",
                                       dir=target.parent if str(target.parent) else ".")
            os.close(fd)
        except OSError as exc:
            raise write_error(target, exc) from None
        self._pending[target] = Path(tmp)
        return Path(tmp)

    def write_text(self, target: Path | str, text: str, encoding: str = "utf-8") -> None:
        """Write ``text`` to a temporary file that becomes ``target`` at commit.

        Parameters
        ----------
        target : Path or str
            The final output path.
        text : str
            The text to write.
        encoding : str
            Text encoding (default UTF-8).

        Raises
        ------
        OutputWriteError
            The write failed (e.g. the disk is full); the temporary file is removed.
        """
        tmp = self.path(target)
        try:
            with open(tmp, "w", encoding=encoding, newline="") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
        except OSError as exc:
            self.discard()
            raise write_error(target, exc) from None

    def commit(self) -> None:
        """Rename every temporary file over its target (or, exclusive, link it where nothing is).

        Raises
        ------
        OutputExistsError
            Exclusive: a target appeared since the check (another run wrote it); none of this
            command's targets is left.
        OutputWriteError
            A rename failed; the remaining temporary files are removed.
        """
        if self._exclusive:
            self._commit_exclusive()
            return
        try:
            for target, tmp in list(self._pending.items()):
                try:
                    os.chmod(tmp, _final_mode(target))
                    os.replace(tmp, target)
                except OSError as exc:
                    raise write_error(target, exc) from None
                del self._pending[target]
        finally:
            self.discard()

    def _commit_exclusive(self) -> None:
        """Check and write in one step, all the targets or none.

        ``link(2)`` fails when the target exists: ``O_EXCL``'s guarantee, for a file written
        first under another name.
        """
        from motorid.errors import OutputExistsError

        done: list[Path] = []
        try:
            for target, tmp in self._pending.items():
                try:
                    os.chmod(tmp, _final_mode(target))
                    os.link(tmp, target)
                except OSError as exc:
                    for t in done:  # none of this command's targets stays
                        with contextlib.suppress(OSError):
                            t.unlink()
                    if isinstance(exc, FileExistsError):
                        raise OutputExistsError("already exists (another run wrote it meanwhile); use "
                                                f"{switch_words('--force', 'force')} to overwrite it",
                                                file=str(target)) from None
                    raise write_error(target, exc) from None
                done.append(target)
        finally:
            self.discard()

    def discard(self) -> None:
        """Remove every temporary file; the targets are left as they were."""
        for tmp in self._pending.values():
            with contextlib.suppress(OSError):
                tmp.unlink()
        self._pending.clear()


@contextlib.contextmanager
def atomic_outputs(*, exclusive: bool = False) -> Iterator[AtomicOutputs]:
    """Collect a command's outputs and commit them together when the block succeeds.

    Parameters
    ----------
    exclusive : bool
        Never overwrite (the command line without ``--force``): a target that appeared since
        :func:`motorid.io.check_writable` looked is refused at commit, in one step with the
        write, and none of the command's targets is written.

    Yields
    ------
    AtomicOutputs
        Write with ``outs.write_text(target, text)`` or into ``outs.path(target)``.

    Raises
    ------
    OutputWriteError
        Writing or renaming failed (disk full, permissions): nothing was written.

    Examples
    --------
    >>> with atomic_outputs() as outs:                     # doctest: +SKIP
    ...     outs.write_text(json_out, model.to_json_text())
    ...     outs.write_text(report_out, make_report(...))  # a failure here leaves no JSON
    """
    outs = AtomicOutputs(exclusive=exclusive)
    try:
        yield outs
    except BaseException:
        outs.discard()
        raise
    try:
        outs.commit()
    except MotorIdError:  # commit's own one-line error (an OSError too): as it is
        raise
    except OSError as exc:  # pragma: no cover - commit maps its own errors
        raise write_error("the output", exc) from None


@contextlib.contextmanager
def atomic_folder(folder: Path | str, targets: Iterable[Path | str]) -> Iterator[Path]:
    """Fill ``folder`` with ``targets`` (files or sub-folders) all-or-nothing.

    Existing targets are moved aside into a hidden folder inside ``folder`` first (a rename,
    same file system); on success they are deleted, on failure whatever the block created
    among the targets is removed and the old ones are put back.  A ``folder`` created here
    is removed again on failure when it is left empty.

    Parameters
    ----------
    folder : Path or str
        The folder to fill (created when missing).
    targets : iterable of Path or str
        The files or sub-folders the block writes into ``folder``.

    Yields
    ------
    Path
        ``folder``.

    Raises
    ------
    OutputWriteError
        The folder cannot be created or a target cannot be moved aside; or an ``OSError``
        raised inside the block (mapped, with everything rolled back).
    """
    folder = Path(folder)
    paths = [Path(t) for t in targets]
    created = not folder.exists()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        backup = Path(tempfile.mkdtemp(prefix=".motorid-backup-", dir=folder))
    except OSError as exc:
        raise write_error(folder, exc) from None
    moved: list[Path] = []

    def rollback() -> None:
        for t in paths:
            if t.is_dir() and not t.is_symlink():
                shutil.rmtree(t, ignore_errors=True)
            else:
                with contextlib.suppress(OSError):
                    t.unlink()
        for t in moved:
            with contextlib.suppress(OSError):
                os.replace(backup / t.name, t)
        shutil.rmtree(backup, ignore_errors=True)
        if created:
            with contextlib.suppress(OSError):
                folder.rmdir()

    try:
        for t in paths:
            if t.exists() or t.is_symlink():
                os.replace(t, backup / t.name)
                moved.append(t)
    except OSError as exc:
        rollback()
        raise write_error(folder, exc) from None
    try:
        yield folder
    except MotorIdError:  # a user-facing error of the block (some are OSErrors too): as it is
        rollback()
        raise
    except OSError as exc:
        rollback()
        raise write_error(folder, exc) from None
    except BaseException:
        rollback()
        raise
    shutil.rmtree(backup, ignore_errors=True)
