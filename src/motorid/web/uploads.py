"""Uploads of the local web app.

Streamed into one folder, names sanitised, zips unpacked safely, files grouped into captures.

No name a browser sends is ever opened as a path.  Each stored file gets a name built from
the last two components of the name it was sent under (``ALL0000/F0000CH1.CSV``: the scope
folder and the file) with every character outside ``[A-Za-z0-9._-]`` replaced, so nothing
can point outside the upload folder; a ``.zip`` is read member by member (never
``extractall``), its members renamed the same way, symlinks skipped, sizes capped.  The
multipart body is parsed by ``python-multipart`` with its upload folder set to the tab's
own, so no part of an upload is spooled anywhere else.
"""

from __future__ import annotations

import os
import re
import shutil
import stat
import zipfile
from collections.abc import AsyncIterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

from python_multipart.multipart import Field, File, FormParser, parse_options_header

from motorid.frozen import frozen_getstate, frozen_setstate
from motorid.errors import MotorIdError, UploadError

__all__ = [
    "CaptureFiles",
    "StoredFile",
    "UploadLimits",
    "UploadedForm",
    "as_uploaded",
    "group_captures",
    "receive_form",
    "safe_name",
]

#: Characters kept in stored names; everything else becomes ``_``.
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
#: A Tektronix channel file of the 'Save All' layout (``F0000CH1.CSV``).
_TDS_CHANNEL = re.compile(r"^F(\d{4})CH([1-4])\.CSV$", re.IGNORECASE)
#: Suffixes of files that can hold a capture (plain CSV, Tektronix CSV, spreadsheet export, a tab-separated
#: or serial-monitor log saved as text); the readers decide from the content.
CAPTURE_SUFFIXES: tuple[str, ...] = (".csv", ".xlsx", ".tsv", ".txt")
_COPY_BLOCK = 1 << 16


@dataclass(frozen=True, slots=True)
class UploadLimits:
    """What one upload may hold.

    Attributes
    ----------
    max_bytes : int
        Size of the whole request body [bytes] (``motorid serve --max-upload-mb``).
    max_files : int
        Files in one upload, members of zips included.
    max_fields : int
        Plain (non-file) form fields.
    max_unzipped_bytes : int
        Total size of the members of the zips of one upload [bytes].
    """

    max_bytes: int = 50 * 1024 * 1024
    max_files: int = 200
    max_fields: int = 64
    max_unzipped_bytes: int = 200 * 1024 * 1024


@dataclass(frozen=True, slots=True)
class StoredFile:
    """One uploaded file as stored.

    Attributes
    ----------
    field : str
        The form field it came in (``files``, ``position``…).
    name : str
        Its sanitised relative name (``ALL0000/F0000CH1.CSV`` or ``run.csv``).
    path : Path
        Where it is stored (inside the upload folder).
    """

    field: str
    name: str
    path: Path


@dataclass(frozen=True, slots=True)
class UploadedForm:
    """A parsed multipart form: the stored files and the plain fields.

    Attributes
    ----------
    files : tuple of StoredFile
        In the order they were sent (zip members in place of their zip).
    fields : Mapping[str, tuple of str]
        Plain fields by name (a field may repeat).
    folder : Path
        The folder holding this upload's files.
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    files: tuple[StoredFile, ...]
    fields: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    folder: Path = Path()

    def __post_init__(self) -> None:
        object.__setattr__(self, "fields", MappingProxyType(dict(self.fields)))


@dataclass(frozen=True, slots=True)
class CaptureFiles:
    """The files of one capture: a Tektronix CH1/CH2… set, or one CSV/``.xlsx`` file.

    Attributes
    ----------
    label : str
        What the page shows (``ALL0000/F0000CH1.CSV + F0000CH2.CSV``).
    paths : tuple of Path
        The files, channels in order.
    field : str
        The form field the files came in.
    """

    label: str
    paths: tuple[Path, ...]
    field: str = "files"

    def reader_argument(self) -> str | list[str]:
        """The argument :func:`motorid.io.read_capture` takes.

        Returns
        -------
        str or list of str
            One path, or the channel files in order.
        """
        return str(self.paths[0]) if len(self.paths) == 1 else [str(p) for p in self.paths]


def safe_name(sent: str) -> str:
    r"""The stored relative name of a file sent as ``sent``.

    Parameters
    ----------
    sent : str
        The file name (possibly a relative path, with ``/`` or ``\\``) the client sent.

    Returns
    -------
    str
        ``folder/file`` or ``file``: at most the last two components, each reduced to
        ``[A-Za-z0-9._-]``, no component empty, ``.`` or ``..`` or starting with a dot.
    """
    parts = [p for p in re.split(r"[\\/]+", sent) if p not in ("", ".", "..")]
    clean = []
    for part in parts[-2:]:
        text = _UNSAFE.sub("_", part).lstrip(".")[-100:]
        clean.append(text or "file")
    return "/".join(clean) if clean else "file"


def _unique(folder: Path, name: str) -> Path:
    """``folder/name``, with ``-2``, ``-3``… before the suffix when it exists already."""
    target = folder / name
    stem, suffix = os.path.splitext(target.name)
    k = 2
    while target.exists():
        target = target.with_name(f"{stem}-{k}{suffix}")
        k += 1
    # belt and braces: a sanitised name cannot leave the folder, but never trust one check
    if folder.resolve() not in target.resolve().parents:
        raise UploadError(f"file name {name!r} is not allowed: rename the file")
    target.parent.mkdir(parents=True, exist_ok=True)
    return target


def _content_type(headers: Mapping[str, str]) -> tuple[str, bytes]:
    ctype, options = parse_options_header(headers.get("content-type", ""))
    kind = ctype.decode("latin-1").lower()
    if kind != "multipart/form-data" or b"boundary" not in options:
        raise UploadError(f"expected a multipart/form-data upload, got {kind or 'no content type'!r}: "
                          "send the capture files as form fields")
    return kind, options[b"boundary"]


async def receive_form(headers: Mapping[str, str], body: AsyncIterator[bytes], folder: Path,
                       limits: UploadLimits) -> UploadedForm:
    """Stream a multipart body into ``folder`` (created), unpacking zips, within ``limits``.

    Parameters
    ----------
    headers : Mapping[str, str]
        The request headers (lower-case names: ``content-type``, ``content-length``).
    body : async iterator of bytes
        The request body (``request.stream()``).
    folder : Path
        A new folder for this upload; it is removed again when the upload is refused.
    limits : UploadLimits
        Size and count limits.

    Returns
    -------
    UploadedForm
        The stored files and plain fields.

    Raises
    ------
    UploadError
        Not a multipart form, too large, too many files or fields, a malformed body, an
        unreadable or unsafe zip.  Nothing of the upload is left behind.
    """
    _, boundary = _content_type(headers)
    mb = limits.max_bytes / (1024 * 1024)
    declared = headers.get("content-length")
    if declared is not None and declared.isdigit() and int(declared) > limits.max_bytes:
        raise UploadError(f"the upload is {int(declared) / 2**20:.3g} MB, more than the limit of {mb:.3g} MB: send "
                          "fewer files, or start the server with a larger motorid serve --max-upload-mb")
    folder.mkdir(parents=True, exist_ok=False)
    incoming = folder / ".incoming"
    incoming.mkdir()
    raw: list[tuple[str, str, File]] = []
    fields: dict[str, list[str]] = {}

    def on_field(f: Field) -> None:
        if sum(len(v) for v in fields.values()) >= limits.max_fields:
            raise UploadError(f"more than {limits.max_fields} form fields: send the options once each")
        name = (f.field_name or b"").decode("utf-8", "replace")
        fields.setdefault(name, []).append((f.value or b"").decode("utf-8", "replace"))

    def on_file(f: File) -> None:
        if len(raw) >= limits.max_files:
            raise UploadError(f"more than {limits.max_files} files in one upload: send fewer files at a time")
        raw.append(((f.field_name or b"").decode("utf-8", "replace"),
                    (f.file_name or b"").decode("utf-8", "replace"), f))

    config = {"UPLOAD_DIR": str(incoming), "MAX_MEMORY_FILE_SIZE": 0, "UPLOAD_DELETE_TMP": False,
              "MAX_BODY_SIZE": limits.max_bytes}
    parser = FormParser("multipart/form-data", on_field, on_file, boundary=boundary, config=config)
    received = 0
    try:
        async for chunk in body:
            received += len(chunk)
            if received > limits.max_bytes:
                raise UploadError(f"the upload is more than the limit of {mb:.3g} MB: send fewer files, or start the "
                                  "server with a larger motorid serve --max-upload-mb")
            parser.write(chunk)
        parser.finalize()
        stored = [_store(fname, sent, f, folder) for fname, sent, f in raw]
        files = _unpack_zips(stored, folder, limits)
    except UploadError:
        _close_all(raw)
        shutil.rmtree(folder, ignore_errors=True)
        raise
    except Exception as exc:  # python-multipart's parse errors: a malformed body is the client's
        _close_all(raw)
        shutil.rmtree(folder, ignore_errors=True)
        raise UploadError(f"the upload is not a well-formed multipart form ({type(exc).__name__}: {exc})") from None
    shutil.rmtree(incoming, ignore_errors=True)
    if not files and not fields:
        shutil.rmtree(folder, ignore_errors=True)
        raise UploadError("the upload holds no files: choose or drop capture files (CSV pairs, ALLnnnn folders, "
                          ".zip, .xlsx, plain CSV)")
    return UploadedForm(tuple(files), {k: tuple(v) for k, v in fields.items()}, folder)


def _close_all(raw: list[tuple[str, str, File]]) -> None:
    for _, _, f in raw:
        f.close()


def _store(field_name: str, sent: str, f: File, folder: Path) -> StoredFile:
    """Move a parsed part from the incoming folder to its sanitised name."""
    name = safe_name(sent)
    target = _unique(folder, name)
    if f.in_memory:  # an empty part never reaches the disk
        target.write_bytes(f.file_object.getvalue())  # type: ignore[union-attr]
        f.close()
    else:
        f.close()
        os.replace(os.fsdecode(f.actual_file_name or b""), target)
    return StoredFile(field_name, target.relative_to(folder).as_posix(), target)


def _unpack_zips(stored: list[StoredFile], folder: Path, limits: UploadLimits) -> list[StoredFile]:
    """Replace every ``.zip`` by its members (sanitised names, sizes capped, no symlinks)."""
    out: list[StoredFile] = []
    unzipped = 0
    for item in stored:
        if item.path.suffix.lower() != ".zip":
            out.append(item)
            continue
        zip_folder = folder / Path(item.name).stem
        try:
            with zipfile.ZipFile(item.path) as zf:
                members = [m for m in zf.infolist() if not m.is_dir()]
                for m in members:
                    if stat.S_ISLNK(m.external_attr >> 16) or m.filename.lower().endswith(".zip"):
                        continue  # a link could point anywhere; a zip in a zip is not unpacked
                    if len(out) >= limits.max_files:
                        raise UploadError(f"{item.name}: more than {limits.max_files} files in one upload")
                    target = _unique(zip_folder, safe_name(m.filename))
                    unzipped += _copy_capped(zf, m, target, limits.max_unzipped_bytes - unzipped, item.name)
                    out.append(StoredFile(item.field, target.relative_to(folder).as_posix(), target))
        except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, RuntimeError, EOFError) as exc:
            raise UploadError(f"{item.name}: not a readable zip archive ({exc}): zip the ALLnnnn folders "
                              "again, or drop the files themselves") from None
        item.path.unlink()
    return out


def _copy_capped(zf: zipfile.ZipFile, member: zipfile.ZipInfo, target: Path, room: int, zip_name: str) -> int:
    """Copy one member, counting the bytes actually inflated (a header's size can lie)."""
    copied = 0
    with zf.open(member) as src, open(target, "xb") as dst:
        while block := src.read(_COPY_BLOCK):
            copied += len(block)
            if copied > room:
                raise UploadError(f"{zip_name}: the archive unpacks to more than the limit of "
                                  f"{(copied + 1) // 2**20 or 1} MB of files: send the captures themselves")
            dst.write(block)
    return copied


def group_captures(files: tuple[StoredFile, ...] | list[StoredFile]) -> tuple[list[CaptureFiles], list[str]]:
    """Group stored files into captures.

    Tektronix channel files ``FnnnnCHk.CSV`` of one folder and one number form one capture
    (channels in order: CH1 = input, CH2 = output); every other ``.csv``/``.xlsx`` file is
    a capture of its own.

    Parameters
    ----------
    files : sequence of StoredFile
        From :func:`receive_form`.

    Returns
    -------
    (list of CaptureFiles, list of str)
        The captures in upload order, and the names of files that cannot hold a capture
        (scope set-up files, screenshots…).
    """
    groups: dict[tuple[str, str, str], list[tuple[int, StoredFile]]] = {}
    order: list[tuple[str, object]] = []
    ignored: list[str] = []
    for f in files:
        base = f.path.name
        m = _TDS_CHANNEL.match(re.sub(r"-\d+(?=\.)", "", base))
        if m:
            key = (f.field, str(Path(f.name).parent), m.group(1))
            if key not in groups:
                groups[key] = []
                order.append(("tds", key))
            groups[key].append((int(m.group(2)), f))
        elif f.path.suffix.lower() in CAPTURE_SUFFIXES:
            order.append(("one", f))
        else:
            ignored.append(f.name)
    captures: list[CaptureFiles] = []
    for kind, item in order:
        if kind == "one":
            assert isinstance(item, StoredFile)
            captures.append(CaptureFiles(item.name, (item.path,), item.field))
            continue
        chans = sorted(groups[item], key=lambda cf: cf[0])  # type: ignore[index]
        names = [cf[1].name for cf in chans]
        label = names[0] + "".join(" + " + Path(n).name for n in names[1:])
        captures.append(CaptureFiles(label, tuple(cf[1].path for cf in chans), chans[0][1].field))
    return captures, ignored


def as_uploaded(exc: MotorIdError, folder: Path) -> MotorIdError:
    """The same error naming files as they were uploaded, not by their place on the server.

    Parameters
    ----------
    exc : MotorIdError
        An error from the library.
    folder : Path
        The upload folder whose path is cut from the message and the file name.

    Returns
    -------
    MotorIdError
        Of the same class.
    """
    prefix = str(folder) + os.sep

    def cut(text: str | None) -> str | None:
        return None if text is None else text.replace(prefix, "").replace(str(folder), ".")

    return type(exc)(cut(exc.message) or "", file=cut(exc.file), row=exc.row)
