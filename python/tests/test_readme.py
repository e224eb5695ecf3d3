"""The README's Python snippets run as written, from any folder (issue 31:
every README snippet runs as written, checked by CI)."""

import re
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_readmes_python_snippets_run_as_written(tmp_path, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert blocks, "the README has Python snippets"
    monkeypatch.chdir(tmp_path)
    with warnings.catch_warnings():
        # Rows outside the identified ranges are named in warnings: allowed.
        warnings.simplefilter("ignore")
        for i, block in enumerate(blocks):
            exec(compile(block, f"README.md python block {i + 1}", "exec"), {})
    assert (tmp_path / "ur10e.cal").exists()
