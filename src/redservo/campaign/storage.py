"""``samples.csv`` and ``samples.parquet``: the resumable, locked store of a campaign's rows.

The store (docs/campaigns.md, "Storage") keeps one row per (sample, method):

* an exclusive lock on the output directory for the whole campaign
  (:class:`~redservo.campaign.lock.DirectoryLock`; ``wait=True`` waits for the holder);
* rows are appended in batches, each batch with one ``write(2)`` on a descriptor opened
  ``O_APPEND`` and then ``fsync``: a crash can only leave the last line incomplete;
* on resume, a last line without its newline (torn), a line that does not parse, and a
  second row for a (sample, method) pair are removed (a finished row wins over an
  ``error`` row) and the file is rewritten atomically (temporary file, ``fsync``, rename);
* a damaged ``definition.json`` or header says what is damaged; ``repair=True`` rebuilds
  them, keeping the rows whose sample parameters match this definition and seed;
* tampering is refused, not resumed: a ``definition.json`` whose content no longer gives
  its fingerprint (edited by hand), and rows whose check (:data:`~redservo.campaign.rowfile.
  SEAL_COLUMN`, each line sealed with the fingerprint) does not match their fields or whose
  method is no method of redservo (a flipped ``success``, a foreign sample or method pasted
  in) are a damage that ``repair=True`` removes (the rows are then computed again); they
  never reach the tables or ``samples.parquet``;
* ``samples.parquet`` (extra ``redservo[parquet]``) mirrors the CSV with a typed schema.

The columns are those of :mod:`redservo.campaign.rows`.
"""

from __future__ import annotations

import csv
import io
import json
import os
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from redservo.campaign.definition import FORMAT_VERSION, CampaignDefinition
from redservo.campaign.lock import DirectoryLock
from redservo.campaign.meta import meta_problem
from redservo.campaign.rowfile import SEAL_COLUMN, RowFile, format_line, parse_line, seal_holds
from redservo.campaign.rows import (
    _columns,
    _error_columns,
    _format,
    _parse,
    _sample_columns,
    _summary_columns,
)
from redservo.errors import ConfigurationError, RedservoError

__all__ = ["_Store", "_columns", "_error_columns", "_parse", "_sample_columns", "_summary_columns"]


_PARAMS = ("attempts", "q0_", "n_near", "near_joints", "target_", "noise_", "depth_", "hand_eye_")
"""Columns (or prefixes) that depend only on (definition, seed, sample): checked by repair."""
PARQUET_BATCH = 1024
"""Rows per row group of ``samples.parquet`` (written one group at a time)."""

Key = tuple[int, str]


def _methods() -> tuple[str, ...]:
    """The methods a row may name (every registered law)."""
    from redservo.redundancy import METHODS

    return METHODS


def _stderr(message: str) -> None:
    print(f"redservo campaign: {message}", file=sys.stderr)


def _write_atomic(path: Path, data: bytes) -> None:
    """Write ``path`` through a temporary file, ``fsync`` and rename (never half written)."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    if hasattr(os, "O_DIRECTORY"):
        fd = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


class _Store:
    """``samples.csv`` plus ``definition.json`` in an output directory (module docstring).

    Args:
        out: Output directory (created if needed).
        defn: The campaign definition.
        seed: The campaign seed.
        wait: Wait for another process holding the directory instead of raising.
        repair: Rebuild a damaged or missing ``definition.json`` or header.
        notify: Where one-line notes go (default: stderr).

    Raises:
        ConfigurationError: the directory is in use (and not ``wait``), holds another
            campaign, or is damaged (and not ``repair``); the message says what to do.
    """

    def __init__(
        self,
        out: Path,
        defn: CampaignDefinition,
        seed: int,
        *,
        wait: bool = False,
        repair: bool = False,
        notify: Callable[[str], None] = _stderr,
    ) -> None:
        self.out = out
        self.columns = _columns(defn.nominal.joint_names)
        self.names = [*(c for c, _ in self.columns), SEAL_COLUMN]
        self.seal = defn.fingerprint(seed)
        """Each line of ``samples.csv`` ends with its check under this fingerprint."""
        self.csv = out / "samples.csv"
        self.meta_path = out / "definition.json"
        self.notify = notify
        self.file: RowFile | None = None
        self.errors: set[Key] = set()
        """The (sample, method) pairs whose row in the index is an ``error`` row."""
        self.lock = DirectoryLock(out, wait=wait, notify=notify)
        try:
            self.index: dict[Key, int] = self._open(defn, seed, repair)
            """Byte offset of the row of each (sample, method) in ``samples.csv``, in the
            order the pairs first appear in the file; no row is kept in memory."""
            self.errors &= self.index.keys()
            self.file = RowFile(self.csv, self.columns, seal=self.seal)
        except BaseException:
            self.lock.release()
            raise

    # -- opening -------------------------------------------------------------------------

    def _meta(self, defn: CampaignDefinition, seed: int) -> dict[str, Any]:
        return {
            "fingerprint": defn.fingerprint(seed),
            "seed": seed,
            "format": FORMAT_VERSION,
            "source": defn.source,
            "definition": defn.data,
            "scenario": defn.scenario.data,
        }

    def _meta_problem(self, fp: str, seed: int, source: str) -> str | None:
        """What is wrong with ``definition.json`` (None: it matches); refuses another campaign
        (:func:`redservo.campaign.meta.meta_problem`)."""
        return meta_problem(self.meta_path, self.csv.exists(), self.out, fp, seed, source)

    def _open(self, defn: CampaignDefinition, seed: int, repair: bool) -> dict[Key, int]:
        self.out.mkdir(parents=True, exist_ok=True)
        meta_problem = self._meta_problem(defn.fingerprint(seed), seed, defn.source)
        if not self.csv.exists():  # no rows to lose: a damaged definition.json is replaced
            if meta_problem is not None:
                self.notify(f"{meta_problem}: replaced (there is no samples.csv)")
            _write_atomic(self.meta_path, self._json(self._meta(defn, seed)))
            _write_atomic(self.csv, (",".join(self.names) + "\n").encode())
            return {}
        header_problem, index, dropped = self._read()
        tampered = self._tamper_problem(dropped["tampered"])
        problems = [p for p in (meta_problem, header_problem, tampered) if p]
        if problems and not repair:
            raise self._damaged("; ".join(problems))
        if meta_problem is not None:
            before = len(index)
            index = self._verified(index, defn, seed)
            dropped["not of this campaign"] = before - len(index)
        if problems or any(dropped.values()):
            index = self._rewrite(index)
            what = ", ".join(f"{v} {k}" for k, v in dropped.items() if v) or "no row"
            done = "repaired " + " and ".join(problems) + "; " if problems else ""
            self.notify(f"{self.csv}: {done}removed {what}; kept {len(index)} row(s)")
        if meta_problem is not None:
            _write_atomic(self.meta_path, self._json(self._meta(defn, seed)))
        return index

    def _tamper_problem(self, count: int) -> str | None:
        if not count:
            return None
        return (
            f"{count} row(s) of {self.csv} fail their check (edited by hand, or not written "
            f"for this campaign; e.g. line {self.first_tampered})"
        )

    def _damaged(self, problem: str) -> ConfigurationError:
        return ConfigurationError(
            f"{problem}; rerun with --repair (run_campaign(repair=True)) to rebuild it from "
            "this campaign's definition, keeping the rows of samples.csv that are intact and "
            "match it, or use another output directory",
            argument="out",
        )

    @staticmethod
    def _json(meta: Mapping[str, Any]) -> bytes:
        return (json.dumps(meta, indent=2, default=str) + "\n").encode()

    # -- reading -------------------------------------------------------------------------

    def _header_problem(self, header: list[str]) -> str | None:
        if header == self.names:
            return None
        text, want = ",".join(header), ",".join(self.names)
        if not header or want.startswith(text) or not all(h.isidentifier() for h in header):
            return (
                f"the header of {self.csv} is damaged (line 1 has {len(header)} of the "
                f"{len(self.names)} columns: {text[:40]!r}...)"
            )
        missing = [c for c in self.names if c not in header]
        extra = [c for c in header if c not in self.names]
        raise ConfigurationError(
            f"{self.csv}: its columns are not this version's (missing: "
            f"{', '.join(missing[:5]) or 'none'}; unexpected: {', '.join(extra[:5]) or 'none'}); "
            "written by another redservo version? use another output directory",
            argument="out",
        )

    def _lines(self) -> Iterator[tuple[int, bytes]]:
        """``(byte offset, line)`` of every line after the header, the last one possibly
        without its newline (torn)."""
        with open(self.csv, "rb") as fh:
            offset = len(fh.readline())
            for line in fh:
                yield offset, line
                offset += len(line)

    def _read(self) -> tuple[str | None, dict[Key, int], dict[str, int]]:
        """Header problem, the byte offset of each intact row by (sample, method), and
        counts of what was dropped. Streams the file: no row is kept (only the index and
        which rows are ``error`` rows, :attr:`errors`)."""
        with open(self.csv, "rb") as fh:
            first = fh.readline()
        whole = first.endswith(b"\n")
        header = next(csv.reader(io.StringIO(first.decode("utf-8", errors="replace"))), [])
        problem = self._header_problem(header if whole else [])
        dropped = {"torn": int(not whole and bool(first))}
        dropped |= {"unreadable": 0, "duplicate": 0, "tampered": 0}
        index: dict[Key, int] = {}
        self.first_tampered = 0
        for number, (offset, line) in enumerate(self._lines() if whole else (), start=2):
            if not line.endswith(b"\n"):
                dropped["torn"] = 1
                break
            row = parse_line(self.columns, line, self.seal)
            if row is None:
                dropped["unreadable"] += 1
                continue
            if not seal_holds(line, self.seal) or row["method"] not in _methods():
                dropped["tampered"] += 1
                self.first_tampered = self.first_tampered or number
                continue
            key = (row["sample"], sys.intern(row["method"]))
            error = row["outcome"] == "error"
            if key in index:
                dropped["duplicate"] += 1
                if key not in self.errors or error:
                    continue  # keep the first finished row
            index[key] = offset
            if error:
                self.errors.add(key)
            else:
                self.errors.discard(key)
        return problem, index, dropped

    def row_at(self, offset: int) -> dict[str, Any]:
        """The row whose line starts at byte ``offset`` of ``samples.csv``."""
        with open(self.csv, "rb") as fh:
            fh.seek(offset)
            row = parse_line(self.columns, fh.readline(), self.seal)
        assert row is not None, f"no row at byte {offset} of {self.csv}"
        return row

    def stored_rows(self) -> Iterator[dict[str, Any]]:
        """The rows of the index (one per (sample, method)), read in file order."""
        wanted = set(self.index.values())
        for offset, line in self._lines():
            if offset in wanted:
                row = parse_line(self.columns, line, self.seal)
                assert row is not None
                yield row

    def _verified(
        self, index: dict[Key, int], defn: CampaignDefinition, seed: int
    ) -> dict[Key, int]:
        """The rows whose sample parameters are those this definition and seed draw."""
        from redservo.campaign.sampling import draw_sample

        kinds = {c: k for c, k in self.columns if c.startswith(_PARAMS)}
        expected: dict[int, dict[str, str] | None] = {}
        out = {}
        for key, offset in index.items():
            row = self.row_at(offset)
            i = row["sample"]
            if i not in expected:
                try:
                    cols = _sample_columns(draw_sample(defn, seed, i), defn.nominal.joint_names)
                    expected[i] = {c: _format(cols.get(c), k) for c, k in kinds.items()}
                except RedservoError:
                    expected[i] = None
            want = expected[i]
            if want is not None and all(_format(row[c], k) == want[c] for c, k in kinds.items()):
                out[key] = offset
        return out

    # -- writing -------------------------------------------------------------------------

    def _line(self, row: Mapping[str, Any]) -> str:
        return format_line(self.columns, row, self.seal)

    def _rewrite(self, index: dict[Key, int]) -> dict[Key, int]:
        """Rewrite ``samples.csv`` atomically with the rows of ``index`` (in its order), one
        row at a time; return their new offsets."""
        tmp = self.csv.with_name(self.csv.name + ".tmp")
        new: dict[Key, int] = {}
        with open(tmp, "wb") as fh:
            fh.write((",".join(self.names) + "\n").encode())
            for key, offset in index.items():
                new[key] = fh.tell()
                fh.write(self._line(self.row_at(offset)).encode())
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, self.csv)
        if hasattr(os, "O_DIRECTORY"):
            fd = os.open(self.csv.parent, os.O_RDONLY | os.O_DIRECTORY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        return new

    def normalize(self, row: Mapping[str, Any]) -> dict[str, Any]:
        """The row as it reads back from the file (so fresh and reused rows are identical)."""
        parsed = parse_line(self.columns, self._line(row).encode(), self.seal)
        assert parsed is not None
        return parsed

    def append(self, rows: Sequence[Mapping[str, Any]] | Mapping[str, Any]) -> list[int]:
        """Append one row or a batch of rows: one ``write(2)``, then ``fsync``; the index
        points at them (a new row replaces an older one of its (sample, method)). Returns
        their byte offsets."""
        batch = [rows] if isinstance(rows, Mapping) else list(rows)
        if self.file is None:
            raise ConfigurationError(f"the store of {self.out} is closed")
        offsets = self.file.append(batch)
        for row, offset in zip(batch, offsets):
            key = (int(row["sample"]), sys.intern(str(row["method"])))
            self.index[key] = offset
            if row.get("outcome") == "error":
                self.errors.add(key)
            else:
                self.errors.discard(key)
        return offsets

    def write_parquet(self, fingerprint: str, batch: int = PARQUET_BATCH) -> Path | None:
        """Write ``samples.parquet`` (typed schema) from the rows of the index, in its order,
        ``batch`` rows at a time (one row group each); None when pyarrow is not installed."""
        from redservo.campaign.parquet import write_rows

        path = self.out / "samples.parquet"
        return write_rows(path, self.columns, self._rows_in_index_order(), fingerprint, batch)

    def _rows_in_index_order(self) -> Iterator[dict[str, Any]]:
        """The rows of the index in its order, read with one open file."""
        with open(self.csv, "rb") as fh:
            for offset in self.index.values():
                fh.seek(offset)
                row = parse_line(self.columns, fh.readline(), self.seal)
                assert row is not None
                yield row

    def close(self) -> None:
        """Close the file and release the directory lock (idempotent)."""
        if self.file is not None:
            self.file.close()
            self.file = None
        self.lock.release()
