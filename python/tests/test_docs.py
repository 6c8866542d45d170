"""docs/PYTHON.md's notebook session runs as written: its ```python blocks, in order, in one
namespace (a block that raises fails the test)."""

import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "PYTHON.md"


def test_the_guides_examples_run(capsys):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)
    assert len(blocks) >= 2, "the guide has its examples"
    namespace = {}
    for i, block in enumerate(blocks):
        exec(compile(block, f"{DOC.name} block {i + 1}", "exec"), namespace)
    out = capsys.readouterr().out
    assert "rounds" in out and "aggregations" in out
