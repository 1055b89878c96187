"""``samples.parquet``: the typed mirror of a campaign's checked rows.

Written from the rows of the store's index (each one's check verified on resume,
:mod:`redservo.campaign.storage`), in its order, one row group per batch; the schema's
metadata carries the campaign's fingerprint and the row format (the CSV's ``row_check``
column is not mirrored). Needs pyarrow (extra ``redservo[parquet]``).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from redservo.campaign.definition import FORMAT_VERSION

__all__ = ["write_rows"]


def write_rows(
    path: Path,
    columns: Sequence[tuple[str, str]],
    rows: Iterable[dict[str, Any]],
    fingerprint: str,
    batch: int,
) -> Path | None:
    """Write ``rows`` (dicts of ``columns``) to ``path`` through a temporary file, ``batch``
    rows per row group; None when pyarrow is not installed."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return None
    types = {"int": pa.int64(), "int?": pa.int64(), "float": pa.float64(), "bool": pa.bool_()}
    schema = pa.schema(
        [pa.field(c, types.get(k, pa.string()), nullable=k == "int?") for c, k in columns],
        metadata={"fingerprint": fingerprint, "format": str(FORMAT_VERSION)},
    )
    tmp = path.with_name(path.name + ".tmp")
    chunks: list[dict[str, Any]] = []
    written = 0
    with pq.ParquetWriter(tmp, schema) as writer:
        for row in rows:
            chunks.append(row)
            if len(chunks) == batch:
                writer.write_table(pa.Table.from_pylist(chunks, schema=schema))
                written += len(chunks)
                chunks = []
        if chunks or not written:
            writer.write_table(pa.Table.from_pylist(chunks, schema=schema))
    os.replace(tmp, path)
    return path
