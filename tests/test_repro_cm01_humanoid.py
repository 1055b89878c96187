"""CM01 §V-B (humanoid) reproduction, and the ``name[i]`` override syntax it relies on."""

from __future__ import annotations

import pytest

from redservo.errors import ScenarioError
from redservo.scenario import apply_overrides, load_scenario


def test_override_selects_an_entry_of_an_array_of_tables() -> None:
    sc = load_scenario("cm01-humanoid-sphere")
    out = apply_overrides(sc, ['features[0].variant="paper"', "objects[0].radius=0.12"])
    assert out.data["features"][0]["variant"] == "paper"
    assert out.data["objects"][0]["radius"] == 0.12
    assert sc.data["features"][0]["variant"] == "exact"  # the original is untouched


@pytest.mark.parametrize(
    ("assignment", "message"),
    [
        ('features[1].variant="paper"', r"'features\[1\]' does not exist; indices 0 to 0"),
        ("control[0].lam=0.1", r"'control\[0\]' does not exist; no 'control' tables"),
        ('features[0].variant="nope"', "unknown sphere variant"),
    ],
)
def test_override_index_errors(assignment: str, message: str) -> None:
    with pytest.raises(ScenarioError, match=message):
        apply_overrides(load_scenario("cm01-humanoid-sphere"), [assignment])
