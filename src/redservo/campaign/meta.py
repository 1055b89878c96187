"""``definition.json``: is it this campaign's, intact and unedited?

A campaign directory's ``definition.json`` holds the definition, the base scenario, the seed,
the row format and their fingerprint (:func:`~redservo.campaign.definition.fingerprint_of`).
On a rerun it must be this campaign's (same fingerprint) and its own content must still give
that fingerprint: an edited ``definition.json`` (an iteration cap changed by hand) is a damage
that ``--repair`` rewrites, never a campaign resumed under what the file now says.
"""

from __future__ import annotations

import json
from pathlib import Path

from redservo.campaign.definition import FORMAT_VERSION, fingerprint_of
from redservo.errors import ConfigurationError

__all__ = ["meta_problem"]


def meta_problem(
    meta_path: Path, csv_exists: bool, out: Path, fp: str, seed: int, source: str
) -> str | None:
    """What is wrong with ``meta_path`` (None: it is this campaign's, unedited).

    Args:
        meta_path: The directory's ``definition.json``.
        csv_exists: Whether the directory holds ``samples.csv`` (rows that could be lost).
        out: The campaign directory (named in errors).
        fp: This campaign's fingerprint; ``seed`` and ``source`` name it in errors.

    Raises:
        ConfigurationError: the file is another campaign's, or of another row format.
    """
    if not meta_path.exists():
        return f"{meta_path} is missing" if csv_exists else None
    try:
        meta = json.loads(meta_path.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        return f"{meta_path} is damaged (not valid JSON: {exc})"
    except OSError as exc:
        return f"{meta_path} cannot be read ({exc.strerror})"
    if not isinstance(meta, dict) or not isinstance(meta.get("fingerprint"), str):
        return f"{meta_path} is damaged (no 'fingerprint' entry)"
    if meta["fingerprint"] == fp:
        try:
            own = fingerprint_of(meta["definition"], meta["scenario"], meta["seed"])
        except (KeyError, TypeError, ValueError, AttributeError):
            own = None
        if own != fp:
            return (
                f"{meta_path} was edited (its definition, scenario or seed no longer "
                f"give its fingerprint {fp[:12]})"
            )
        return None
    if meta.get("format") != FORMAT_VERSION:
        raise ConfigurationError(
            f"{out} holds a campaign in row format {meta.get('format')!r}; this "
            f"redservo writes format {FORMAT_VERSION} (e.g. 0-based limit_axis since "
            "format 3): use another output directory, or delete it to start over",
            argument="out",
        )
    raise ConfigurationError(
        f"{out} holds a campaign with another definition or seed (fingerprint "
        f"{meta['fingerprint'][:12]} != {fp[:12]} for {source} with seed {seed}); "
        "use another output directory, or delete it to start over",
        argument="out",
    )
