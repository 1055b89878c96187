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
* ``samples.parquet`` (extra ``redservo[parquet]``) mirrors the CSV with a typed schema.

The columns are those of :mod:`redservo.campaign.rows`.
"""

from __future__ import annotations

import csv
import io
import json
import os
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from redservo.campaign.definition import FORMAT_VERSION, CampaignDefinition
from redservo.campaign.lock import DirectoryLock
from redservo.campaign.rows import (
    _columns,
    _error_columns,
    _format,
    _parse,
    _sample_columns,
    _summary_columns,
)
from redservo.errors import ConfigurationError, RedservoError

__all__ = ["_Store", "_error_columns", "_sample_columns", "_summary_columns"]


_PARAMS = ("attempts", "q0_", "n_near", "near_joints", "target_", "noise_", "depth_", "hand_eye_")
"""Columns (or prefixes) that depend only on (definition, seed, sample): checked by repair."""


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
        self.names = [c for c, _ in self.columns]
        self.csv = out / "samples.csv"
        self.meta_path = out / "definition.json"
        self.notify = notify
        self._fd: int | None = None
        self.lock = DirectoryLock(out, wait=wait, notify=notify)
        try:
            self.rows = self._open(defn, seed, repair)
            self._fd = os.open(self.csv, os.O_WRONLY | os.O_APPEND)
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
        """What is wrong with ``definition.json`` (None: it matches); refuses another campaign."""
        if not self.meta_path.exists():
            return f"{self.meta_path} is missing" if self.csv.exists() else None
        try:
            meta = json.loads(self.meta_path.read_bytes().decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            return f"{self.meta_path} is damaged (not valid JSON: {exc})"
        except OSError as exc:
            return f"{self.meta_path} cannot be read ({exc.strerror})"
        if not isinstance(meta, dict) or not isinstance(meta.get("fingerprint"), str):
            return f"{self.meta_path} is damaged (no 'fingerprint' entry)"
        if meta["fingerprint"] == fp:
            return None
        if meta.get("format") != FORMAT_VERSION:
            raise ConfigurationError(
                f"{self.out} holds a campaign in row format {meta.get('format')!r}; this "
                f"redservo writes format {FORMAT_VERSION} (e.g. 0-based limit_axis since "
                "format 3): use another output directory, or delete it to start over",
                argument="out",
            )
        raise ConfigurationError(
            f"{self.out} holds a campaign with another definition or seed (fingerprint "
            f"{meta['fingerprint'][:12]} != {fp[:12]} for {source} with seed {seed}); "
            "use another output directory, or delete it to start over",
            argument="out",
        )

    def _open(
        self, defn: CampaignDefinition, seed: int, repair: bool
    ) -> dict[tuple[int, str], dict[str, Any]]:
        self.out.mkdir(parents=True, exist_ok=True)
        meta_problem = self._meta_problem(defn.fingerprint(seed), seed, defn.source)
        if not self.csv.exists():  # no rows to lose: a damaged definition.json is replaced
            if meta_problem is not None:
                self.notify(f"{meta_problem}: replaced (there is no samples.csv)")
            _write_atomic(self.meta_path, self._json(self._meta(defn, seed)))
            _write_atomic(self.csv, (",".join(self.names) + "\n").encode())
            return {}
        header_problem, rows, dropped = self._read()
        problems = [p for p in (meta_problem, header_problem) if p]
        if problems and not repair:
            raise self._damaged("; ".join(problems))
        if meta_problem is not None:
            before = len(rows)
            rows = self._verified(rows, defn, seed)
            dropped["not of this campaign"] = before - len(rows)
        if problems or any(dropped.values()):
            self._rewrite(rows.values())
            what = ", ".join(f"{v} {k}" for k, v in dropped.items() if v) or "no row"
            done = "repaired " + " and ".join(problems) + "; " if problems else ""
            self.notify(f"{self.csv}: {done}removed {what}; kept {len(rows)} row(s)")
        if meta_problem is not None:
            _write_atomic(self.meta_path, self._json(self._meta(defn, seed)))
        return rows

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

    def _read(self) -> tuple[str | None, dict[tuple[int, str], dict[str, Any]], dict[str, int]]:
        """Header problem, the intact rows by (sample, method), and counts of what was dropped."""
        text = self.csv.read_bytes().decode("utf-8", errors="replace")
        body, _, tail = text.rpartition("\n")
        dropped = {"torn": int(bool(tail)), "unreadable": 0, "duplicate": 0}
        records = list(csv.reader(io.StringIO(body)))
        problem = self._header_problem(records[0] if records else [])
        rows: dict[tuple[int, str], dict[str, Any]] = {}
        for fields in records[1:]:
            row = self._parse_row(fields)
            if row is None:
                dropped["unreadable"] += 1
                continue
            key = (row["sample"], row["method"])
            if key in rows:
                dropped["duplicate"] += 1
                if rows[key]["outcome"] != "error" or row["outcome"] == "error":
                    continue  # keep the first finished row
            rows[key] = row
        return problem, rows, dropped

    def _parse_row(self, fields: list[str]) -> dict[str, Any] | None:
        if len(fields) != len(self.columns) or any("\ufffd" in f for f in fields):
            return None
        try:
            row = {c: _parse(v, k) for (c, k), v in zip(self.columns, fields)}
        except ValueError:
            return None
        return row if row["sample"] >= 0 and row["method"] else None

    def _verified(
        self, rows: dict[tuple[int, str], dict[str, Any]], defn: CampaignDefinition, seed: int
    ) -> dict[tuple[int, str], dict[str, Any]]:
        """The rows whose sample parameters are those this definition and seed draw."""
        from redservo.campaign.sampling import draw_sample

        kinds = {c: k for c, k in self.columns if c.startswith(_PARAMS)}
        expected: dict[int, dict[str, str] | None] = {}
        out = {}
        for key, row in rows.items():
            i = row["sample"]
            if i not in expected:
                try:
                    cols = _sample_columns(draw_sample(defn, seed, i), defn.nominal.joint_names)
                    expected[i] = {c: _format(cols.get(c), k) for c, k in kinds.items()}
                except RedservoError:
                    expected[i] = None
            want = expected[i]
            if want is not None and all(_format(row[c], k) == want[c] for c, k in kinds.items()):
                out[key] = row
        return out

    # -- writing -------------------------------------------------------------------------

    def _line(self, row: Mapping[str, Any]) -> str:
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(
            [_format(row.get(c), k) for c, k in self.columns]
        )
        return buf.getvalue()

    def _rewrite(self, rows: Iterable[Mapping[str, Any]]) -> None:
        text = ",".join(self.names) + "\n" + "".join(self._line(r) for r in rows)
        _write_atomic(self.csv, text.encode())

    def normalize(self, row: Mapping[str, Any]) -> dict[str, Any]:
        """The row as it reads back from the file (so fresh and reused rows are identical)."""
        fields = next(csv.reader(io.StringIO(self._line(row))))
        parsed = self._parse_row(fields)
        assert parsed is not None
        return parsed

    def append(self, rows: Sequence[Mapping[str, Any]] | Mapping[str, Any]) -> None:
        """Append one row or a batch of rows: one ``write(2)``, then ``fsync``."""
        batch = [rows] if isinstance(rows, Mapping) else list(rows)
        if self._fd is None:
            raise ConfigurationError(f"the store of {self.out} is closed")
        data = "".join(self._line(r) for r in batch).encode()
        while data:
            data = data[os.write(self._fd, data) :]
        os.fsync(self._fd)

    def write_parquet(self, rows: Iterable[Mapping[str, Any]], fingerprint: str) -> Path | None:
        """Write ``samples.parquet`` (typed schema); None when pyarrow is not installed."""
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            return None
        types = {"int": pa.int64(), "int?": pa.int64(), "float": pa.float64(), "bool": pa.bool_()}
        schema = pa.schema(
            [pa.field(c, types.get(k, pa.string()), nullable=k == "int?") for c, k in self.columns],
            metadata={"fingerprint": fingerprint, "format": str(FORMAT_VERSION)},
        )
        data = [
            {c: (None if k == "int?" and r.get(c) is None else r.get(c)) for c, k in self.columns}
            for r in rows
        ]
        path = self.out / "samples.parquet"
        tmp = path.with_name(path.name + ".tmp")
        pq.write_table(pa.Table.from_pylist(data, schema=schema), tmp)
        os.replace(tmp, path)
        return path

    def close(self) -> None:
        """Close the file and release the directory lock (idempotent)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        self.lock.release()
