"""docs/PYTHON.md's notebook session runs as written: its ```python blocks, in order, in one
namespace (a block that raises fails the test). The guide's output directory, /tmp/swarmfl-doc,
is replaced by a fresh one per test run: a directory left by another build's run holds results
of other presets, which `sweep` rightly refuses to mix with today's."""

import linecache
import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "PYTHON.md"


def test_the_guides_examples_run(capsys, tmp_path):
    text = DOC.read_text().replace("/tmp/swarmfl-doc", str(tmp_path / "swarmfl-doc"))
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 2, "the guide has its examples"
    namespace = {}
    for i, block in enumerate(blocks):
        # As a notebook does: the cell's text where inspect finds it (a plug-in's source is
        # hashed into the log header).
        name = f"{DOC.name} block {i + 1}"
        linecache.cache[name] = (len(block), None, block.splitlines(True), name)
        exec(compile(block, name, "exec"), namespace)
    out = capsys.readouterr().out
    assert "rounds" in out and "aggregations" in out
