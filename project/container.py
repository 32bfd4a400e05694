"""The ``.sheer`` zip container: a reader that trusts nothing and a deterministic writer.

The container itself is the standard library's :mod:`zipfile`; what this module adds is the policy a
project file must pass before a single byte of it is decoded (it is read by kiosks, unattended):

- entry names are relative POSIX paths: no absolute path, drive letter, backslash, ``..`` or ``.``
  component, empty component, control character, or name longer than :data:`MAX_NAME_LENGTH`;
- no symbolic links (Unix mode bits in the external attributes), no encrypted entries, only the
  stored and deflated methods;
- no duplicate names (also compared case-folded, since the archive may be unpacked on a
  case-insensitive file system);
- at most :data:`MAX_ENTRIES` entries; the declared uncompressed sizes add up to at most
  :data:`MAX_TOTAL_UNCOMPRESSED` bytes; an entry over :data:`RATIO_CHECK_MIN_BYTES` may not declare
  more than :data:`MAX_COMPRESSION_RATIO` times its compressed size (zip bombs);
- reading an entry never returns more bytes than its declared size (``zipfile`` stops there), and its
  CRC-32 is checked.

Every rejection is a :class:`ProjectContainerError` naming the file, the entry and the problem. Nothing
is ever extracted to disk: entries are read into memory.
"""

from __future__ import annotations

import io
import stat
import zipfile
from pathlib import Path
from typing import IO, TYPE_CHECKING

from project.errors import ProjectContainerError

if TYPE_CHECKING:
    from collections.abc import Iterable

#: At most this many entries in a project file.
MAX_ENTRIES = 4096
#: The declared uncompressed sizes of all entries add up to at most this many bytes (2 GiB).
MAX_TOTAL_UNCOMPRESSED = 2 * 1024**3
#: One entry may not be larger than this (bytes, uncompressed): a 8192² float32 map is 256 MiB.
MAX_ENTRY_UNCOMPRESSED = 512 * 1024**2
#: Uncompressed size / compressed size may not exceed this for entries larger than
#: :data:`RATIO_CHECK_MIN_BYTES`. Thickness maps are stored already compressed (EXR's own zip
#: compression, or PNG), so honest entries stay far below it.
MAX_COMPRESSION_RATIO = 200.0
#: Entries smaller than this (bytes, uncompressed) are not subject to the ratio check.
RATIO_CHECK_MIN_BYTES = 1024**2
#: Longest entry name (characters).
MAX_NAME_LENGTH = 255
#: A fixed timestamp for every entry, so saving the same project twice gives identical bytes.
FIXED_DATE_TIME = (2020, 1, 1, 0, 0, 0)


def _tail(fh: IO[bytes]) -> bytes:
    """The last 64 KiB + 22 bytes of a file (where the end-of-central-directory record is)."""
    fh.seek(0, 2)
    size = fh.tell()
    fh.seek(max(0, size - (65535 + 22)))
    return fh.read()


def check_entry_name(name: str) -> str | None:
    """Why ``name`` is not an acceptable entry name, or None when it is."""
    if not name:
        return "empty entry name"
    if len(name) > MAX_NAME_LENGTH:
        return f"entry name longer than {MAX_NAME_LENGTH} characters"
    if any(ord(c) < 32 or ord(c) == 127 for c in name):
        return "control character in entry name"
    if "\\" in name:
        return "backslash in entry name"
    if name.startswith("/"):
        return "absolute path"
    if len(name) >= 2 and name[1] == ":":
        return "drive letter in entry name"
    parts = name.split("/")
    if any(p == ".." for p in parts):
        return "'..' in entry path"
    if any(p in ("", ".") for p in parts[:-1]) or parts[-1] == ".":
        return "empty or '.' path component"
    return None


class SafeZipReader:
    """Read a project container after checking every entry (see the module docstring).

    Use as a context manager; :meth:`read` returns an entry's bytes. ``source`` names the file in
    messages.
    """

    def __init__(self, source: str | Path | IO[bytes], *, name: str | None = None,
                 max_total: int | None = None) -> None:
        self.name = name or str(source)
        self._precheck(source)
        try:
            self._zip = zipfile.ZipFile(source, "r")  # type: ignore[arg-type]
        except FileNotFoundError:
            raise
        except Exception as exc:  # zipfile raises BadZipFile, NotImplementedError, struct.error... on forged headers
            raise ProjectContainerError(f"{self.name}: not a Sheer project (not a readable zip file: {exc})") from None
        try:
            self._infos = self._check(MAX_TOTAL_UNCOMPRESSED if max_total is None else max_total)
        except BaseException:
            self._zip.close()
            raise

    def _precheck(self, source: str | Path | IO[bytes]) -> None:
        """Check the end-of-central-directory record before :mod:`zipfile` parses the directory.

        So a forged directory announcing millions of entries is refused without being parsed.
        """
        try:
            if isinstance(source, (str, Path)):
                with open(source, "rb") as fh:
                    tail = _tail(fh)
            else:
                pos = source.tell()
                tail = _tail(source)
                source.seek(pos)
        except OSError as exc:
            raise ProjectContainerError(f"{self.name}: cannot read ({exc})") from None
        at = tail.rfind(b"PK\x05\x06")
        if at < 0 or len(tail) - at < 22:
            return  # zipfile will say it is not a zip
        entries = int.from_bytes(tail[at + 10:at + 12], "little")
        cd_size = int.from_bytes(tail[at + 12:at + 16], "little")
        if entries != 0xFFFF and entries > MAX_ENTRIES:
            raise ProjectContainerError(f"{self.name}: {entries} entries, over the limit of {MAX_ENTRIES}")
        if cd_size != 0xFFFFFFFF and cd_size > MAX_ENTRIES * (46 + MAX_NAME_LENGTH + 2 * 65535):
            raise ProjectContainerError(f"{self.name}: central directory of {cd_size:,} bytes is too large")

    def _fail(self, entry: str, problem: str) -> ProjectContainerError:
        return ProjectContainerError(f"{self.name}: entry {entry!r}: {problem}")

    def _check(self, max_total: int) -> dict[str, zipfile.ZipInfo]:
        infos = self._zip.infolist()
        if len(infos) > MAX_ENTRIES:
            raise ProjectContainerError(f"{self.name}: {len(infos)} entries, over the limit of {MAX_ENTRIES}")
        seen: dict[str, zipfile.ZipInfo] = {}
        folded: set[str] = set()
        total = 0
        for info in infos:
            name = info.filename
            problem = check_entry_name(name)
            if problem:
                raise self._fail(name, problem)
            if name in seen or name.casefold() in folded:
                raise self._fail(name, "duplicate entry name")
            mode = (info.external_attr >> 16) & 0xFFFF
            if stat.S_ISLNK(mode):
                raise self._fail(name, "symbolic link (links are never followed)")
            if stat.S_IFMT(mode) not in (0, stat.S_IFREG, stat.S_IFDIR):  # 0: no type recorded
                raise self._fail(name, "not a regular file")
            if info.flag_bits & 0x1:
                raise self._fail(name, "encrypted entry")
            if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
                raise self._fail(name, f"unsupported compression method {info.compress_type}")
            if info.file_size < 0 or info.compress_size < 0:
                raise self._fail(name, "negative size")
            if info.file_size > MAX_ENTRY_UNCOMPRESSED:
                raise self._fail(name, f"uncompressed size {info.file_size:,} bytes over the limit of "
                                       f"{MAX_ENTRY_UNCOMPRESSED:,}")
            if info.file_size > RATIO_CHECK_MIN_BYTES:
                ratio = info.file_size / max(info.compress_size, 1)
                if ratio > MAX_COMPRESSION_RATIO:
                    raise self._fail(name, f"compression ratio {ratio:.0f}:1 over the limit of "
                                           f"{MAX_COMPRESSION_RATIO:.0f}:1 (zip bomb?)")
            total += info.file_size
            if total > max_total:
                raise self._fail(name, f"total uncompressed size over the limit of {max_total:,} bytes")
            seen[name] = info
            folded.add(name.casefold())
        return seen

    def __enter__(self) -> SafeZipReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the underlying zip file."""
        self._zip.close()

    def names(self) -> list[str]:
        """Entry names in archive order (directories included, with their trailing '/')."""
        return list(self._infos)

    def files(self) -> list[str]:
        """Names of the file entries (not directories)."""
        return [n for n in self._infos if not n.endswith("/")]

    def size(self, name: str) -> int:
        """Declared uncompressed size of an entry (bytes)."""
        return self._infos[name].file_size

    def __contains__(self, name: object) -> bool:
        return name in self._infos

    def read(self, name: str, max_bytes: int | None = None) -> bytes:
        """The bytes of entry ``name`` (CRC checked); ``max_bytes`` caps the size for this entry."""
        info = self._infos.get(name)
        if info is None:
            raise ProjectContainerError(f"{self.name}: missing entry {name!r}")
        if name.endswith("/"):
            raise self._fail(name, "is a folder, a file was expected")
        if max_bytes is not None and info.file_size > max_bytes:
            raise self._fail(name, f"{info.file_size:,} bytes, over the limit of {max_bytes:,} for this entry")
        try:
            with self._zip.open(info) as fh:
                data = fh.read(info.file_size + 1)
        except Exception as exc:  # BadZipFile (CRC), zlib.error, NotImplementedError, EOFError...
            raise self._fail(name, f"damaged data ({exc})") from None
        if len(data) != info.file_size:
            raise self._fail(name, f"truncated: {len(data)} of {info.file_size} bytes")
        return data


def write_container(fh: IO[bytes], entries: Iterable[tuple[str, bytes, bool]]) -> None:
    """Write a zip to ``fh`` from ``(name, data, compress)`` tuples, in the given order.

    Entries get a fixed timestamp and regular-file permissions, so the bytes depend only on the
    content. Already-compressed data (EXR, PNG) is better stored (``compress=False``).
    """
    with zipfile.ZipFile(fh, "w", allowZip64=True) as zf:
        for name, data, compress in entries:
            problem = check_entry_name(name)
            if problem:
                raise ValueError(f"refusing to write entry {name!r}: {problem}")
            info = zipfile.ZipInfo(name, date_time=FIXED_DATE_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
            info.external_attr = (stat.S_IFREG | 0o644) << 16
            info.create_system = 3  # Unix, so the mode bits above are meaningful
            zf.writestr(info, data, compresslevel=6 if compress else None)


def container_bytes(entries: Iterable[tuple[str, bytes, bool]]) -> bytes:
    """:func:`write_container` into memory."""
    buf = io.BytesIO()
    write_container(buf, entries)
    return buf.getvalue()
