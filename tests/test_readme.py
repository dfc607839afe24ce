"""The README is the front door: its Python blocks run, its set-up commands are what CI runs."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_readme_python_blocks_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert blocks, "README has no python block"
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {})


def test_ci_runs_the_readme_test_command():
    lines = README.splitlines()
    i = next(k for k, line in enumerate(lines) if line.startswith("<!-- test-command"))
    command = lines[i + 2]
    assert "pytest" in command and "venv" in command
    assert "README.md" in (ROOT / ".ci" / "run").read_text()
