"""Declarative schemas of the scenario and campaign files (pydantic v2; docs/decisions.md).

Types, ranges, defaults and documentation live in one place: the models of
:mod:`redservo.schema.scenario` and :mod:`redservo.schema.campaign`. Validating a file
(:func:`validate`) checks every key without building the experiment; errors are one line
naming the file, the key path (``features[1].components``) and what is allowed
(:func:`~redservo.schema.explain.to_error`). ``docs/scenarios.md`` and ``docs/campaigns.md``
carry a reference generated from the models (:mod:`redservo.schema.docs`).
"""

from __future__ import annotations

from redservo.schema.base import Table
from redservo.schema.explain import to_error, validate
from redservo.schema.scenario import ScenarioSpec

__all__ = ["ScenarioSpec", "Table", "to_error", "validate"]
