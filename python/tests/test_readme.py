"""The README's Python example runs as written."""

import re

from conftest import REPO


def test_readme_examples_run(capsys):
    text = (REPO / "README.md").read_text()
    section = text[text.index("## Python") : text.index("## Scale-out")]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(blocks) == 2, "the README's Python section has its two examples"
    exec(compile(blocks[0], "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert "occluded:" in out and "bvh" in out and "crsh" in out and "grid" in out
    # Your own geometry: what the comment says it prints.
    exec(compile(blocks[1], "README.md", "exec"), {})
    assert capsys.readouterr().out.split() == ["[0", "1]", "[2.", "2.]"]
