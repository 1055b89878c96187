"""A campaign's rows on disk: appended as they finish, read back lazily by byte offset.

The client of a campaign keeps no row as a Python dict (docs/scaling.md, "Memory"): each
finished row is appended to a CSV file (the campaign's ``samples.csv``, or a temporary file
when there is no output directory) and only its byte offset is kept; the statistics keep
their columns in :class:`~redservo.campaign.table.RunTable`. :class:`RowView` is
``CampaignResult.rows``: a sequence of row dicts that reads each row back from the file
when asked (so the rows read back are those of the file, bit for bit).

**Sealed rows.** A campaign's ``samples.csv`` is shared and resumed, so each of its lines
ends with one more field, ``row_check`` (:data:`SEAL_COLUMN`): the first 16 hex digits of the
SHA-256 of the campaign's fingerprint and the line's other fields. A row edited by hand (a
flipped ``success``, a foreign sample or method pasted in) no longer matches its check and is
refused on resume (:mod:`redservo.campaign.storage`). It is a check against accidental and
naive edits, not an authentication: the fingerprint is in ``definition.json``.
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
import shutil
import tempfile
import weakref
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, overload

import numpy as np

from redservo.campaign.rows import _format, _parse
from redservo.errors import ConfigurationError

Columns = Sequence[tuple[str, str]]

SEAL_COLUMN = "row_check"
"""The last column of a sealed row file (module docstring)."""


def _check(seal: str, body: str) -> str:
    """The check of a line's fields ``body`` (without its newline) under ``seal``."""
    return hashlib.sha256(f"{seal}\n{body}".encode()).hexdigest()[:16]


def format_line(columns: Columns, row: Mapping[str, Any], seal: str | None = None) -> str:
    """One CSV line (with its newline) of a row, in ``columns`` order; with ``seal`` (the
    campaign's fingerprint), its check as one more field (module docstring)."""
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow([_format(row.get(c), k) for c, k in columns])
    line = buf.getvalue()
    if seal is None:
        return line
    return f"{line[:-1]},{_check(seal, line[:-1])}\n"


def format_lines(
    columns: Columns, rows: Sequence[Mapping[str, Any]], seal: str | None = None
) -> list[str]:
    """:func:`format_line` of each row, by one CSV writer (the same lines)."""
    lines: list[str] = []
    writer = csv.writer(_Collect(lines), lineterminator="\n")
    for row in rows:
        writer.writerow([_format(row.get(c), k) for c, k in columns])
    if len(lines) != len(rows):  # a writer that wrote a row in pieces: one at a time
        lines = [format_line(columns, row) for row in rows]
    if seal is None:
        return lines
    return [f"{line[:-1]},{_check(seal, line[:-1])}\n" for line in lines]


class _Collect:
    """A file-like sink keeping each ``write`` (the CSV writer writes one line a row)."""

    def __init__(self, lines: list[str]) -> None:
        self.write = lines.append


def _body(line: bytes) -> tuple[bytes, bytes]:
    """A sealed line's fields before its check, and the check (a hex field: no quoting)."""
    body, _, check = line.rstrip(b"\r\n").rpartition(b",")
    return body, check


def seal_holds(line: bytes, seal: str) -> bool:
    """Whether a sealed line's check is that of its fields (module docstring)."""
    body, check = _body(line)
    return check.decode("ascii", errors="replace") == _check(
        seal, body.decode("utf-8", errors="replace")
    )


def parse_fields(columns: Columns, fields: list[str]) -> dict[str, Any] | None:
    """The row of one line's fields, or None when they do not make a row of ``columns``."""
    if len(fields) != len(columns) or any("\ufffd" in f for f in fields):
        return None
    try:
        row = {c: _parse(v, k) for (c, k), v in zip(columns, fields)}
    except ValueError:
        return None
    return row if row["sample"] >= 0 and row["method"] else None


def parse_line(columns: Columns, line: bytes, seal: str | None = None) -> dict[str, Any] | None:
    """The row of one line of the file (bytes, with or without its newline), or None; a
    sealed line (``seal`` given) without its check field (:func:`seal_holds` checks it)."""
    if seal is not None:
        line = _body(line)[0]
    records = list(csv.reader(io.StringIO(line.decode("utf-8", errors="replace"))))
    return parse_fields(columns, records[0]) if len(records) == 1 else None


class RowFile:
    """An append-only CSV file of rows whose header is already written.

    Args:
        path: The file.
        columns: ``(column, type)`` pairs (:func:`redservo.campaign.rows._columns`).
        durable: ``fsync`` after every batch (the campaign's ``samples.csv``).
        seal: The campaign's fingerprint: each line ends with its check (module docstring).
    """

    def __init__(
        self, path: Path, columns: Columns, *, durable: bool = True, seal: str | None = None
    ) -> None:
        self.path = path
        self.columns = list(columns)
        self.durable = durable
        self.seal = seal
        self._fd: int | None = os.open(path, os.O_WRONLY | os.O_APPEND)
        self.size = os.fstat(self._fd).st_size

    def append(self, rows: Sequence[Mapping[str, Any]]) -> list[int]:
        """Append a batch of rows with one ``write(2)`` (then ``fsync`` when durable); return
        the byte offset of each row's line."""
        if self._fd is None:
            raise ConfigurationError(f"the row file {self.path} is closed")
        lines = [line.encode() for line in format_lines(self.columns, rows, self.seal)]
        offsets = []
        for line in lines:
            offsets.append(self.size)
            self.size += len(line)
        data = b"".join(lines)
        while data:
            data = data[os.write(self._fd, data) :]
        if self.durable:
            os.fsync(self._fd)
        return offsets

    def close(self) -> None:
        """Close the descriptor (idempotent); the file stays."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def temporary_file(columns: Columns) -> tuple[RowFile, Path]:
    """A :class:`RowFile` with its header in a new temporary directory (no ``fsync``), and
    that directory (the caller removes it: :func:`remove_with`)."""
    folder = Path(tempfile.mkdtemp(prefix="redservo-campaign-"))
    path = folder / "rows.csv"
    path.write_text(",".join(c for c, _ in columns) + "\n")
    return RowFile(path, columns, durable=False), folder


def remove_with(owner: object, folder: Path) -> None:
    """Remove ``folder`` when ``owner`` is garbage collected (or at exit)."""
    weakref.finalize(owner, shutil.rmtree, folder, True)


class RowView(Sequence[dict[str, Any]]):
    """Rows read back lazily from a :class:`RowFile` (``CampaignResult.rows``).

    Holds per row only its byte offset, sample number and method (13 bytes); each access
    reads and parses the line. A row whose line no longer holds that (sample, method)
    (the file was rewritten since, e.g. by a later resumed campaign in the same directory)
    raises :class:`~redservo.errors.ConfigurationError`.

    Args:
        path: The CSV file.
        columns: Its columns.
        offsets: Byte offset of each row's line, in the view's order.
        samples: Sample number of each row.
        methods: Method of each row (index into ``names``).
        names: The methods.
        seal: The file's seal (sealed lines), or None.
    """

    def __init__(
        self,
        path: Path,
        columns: Columns,
        offsets: np.ndarray,
        samples: np.ndarray,
        methods: np.ndarray,
        names: Sequence[str],
        seal: str | None = None,
    ) -> None:
        self.path = path
        self.seal = seal
        self.columns = list(columns)
        self._offsets = np.asarray(offsets, dtype=np.int64)
        self._samples = np.asarray(samples, dtype=np.int32)
        self._methods = np.asarray(methods, dtype=np.int8)
        self._names = tuple(names)

    def __len__(self) -> int:
        return int(self._offsets.size)

    def _read(self, fh: Any, k: int) -> dict[str, Any]:
        fh.seek(int(self._offsets[k]))
        row = parse_line(self.columns, fh.readline(), self.seal)
        want = (int(self._samples[k]), self._names[int(self._methods[k])])
        if row is None or (row["sample"], row["method"]) != want:
            raise ConfigurationError(
                f"{self.path} changed since the campaign ended (the row of sample {want[0]} "
                f"{want[1]} is no longer where it was written); read the file itself"
            )
        return row

    @overload
    def __getitem__(self, k: int) -> dict[str, Any]: ...

    @overload
    def __getitem__(self, k: slice) -> tuple[dict[str, Any], ...]: ...

    def __getitem__(self, k: int | slice) -> dict[str, Any] | tuple[dict[str, Any], ...]:
        if isinstance(k, slice):
            ids = range(len(self))[k]
            with open(self.path, "rb") as fh:
                return tuple(self._read(fh, j) for j in ids)
        j = range(len(self))[k]  # IndexError as a sequence raises it
        with open(self.path, "rb") as fh:
            return self._read(fh, j)

    def __iter__(self) -> Iterator[dict[str, Any]]:
        with open(self.path, "rb") as fh:
            for k in range(len(self)):
                yield self._read(fh, k)

    def __repr__(self) -> str:
        return f"RowView({len(self)} rows of {self.path})"
