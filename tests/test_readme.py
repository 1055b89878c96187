"""The README's Python examples run as written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_readme_has_the_quickstart_and_the_law_example() -> None:
    assert len(BLOCKS) >= 2


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_block_runs(index: int, capsys: pytest.CaptureFixture[str]) -> None:
    exec(compile(BLOCKS[index], f"README.md block {index}", "exec"), {})
    out = capsys.readouterr().out
    if "simulate(" in BLOCKS[index]:
        # The quick-start's claim: classical hits a limit, iterative-smooth converges.
        assert "classical joint_limit" in out and "iterative-smooth converged None" in out
        assert "classical success: False" in out and "iterative-smooth success: True" in out
    if 'redservo.load_scenario("cm01-gaze"' in BLOCKS[index]:
        # The quick-start's comment says what its first print shows (it promised 0.04 once).
        said = re.search(r"q\.shape\)\s+# (\S+) ([\d.]+)\.\.\. (\(\d+, \d+\))", BLOCKS[index])
        assert said is not None, "the quick-start's first print has no comment of what it prints"
        outcome, margin, shape = said.groups()
        first = out.splitlines()[0]
        assert first.startswith(f"{outcome} {margin}") and first.endswith(shape), first
