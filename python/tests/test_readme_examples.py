"""The README's Python examples work as written: its agent completes a `bw4t run` match on
the `fixed` map alone, and its training snippet runs to its end."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path
from typing import List

from conftest import REPO


def readme_python_blocks() -> List[str]:
    """Every ```python block of the README, in order."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    return re.findall(r"^```python\n(.*?)^```$", text, flags=re.MULTILINE | re.DOTALL)


def the_block_with(marker: str) -> str:
    """The one README block that contains `marker`."""
    found = [block for block in readme_python_blocks() if marker in block]
    assert len(found) == 1, f"the README should have one ```python block with {marker!r}, not {len(found)}"
    return found[0]


def test_the_readme_has_its_two_examples() -> None:
    blocks = readme_python_blocks()
    assert len(blocks) == 2, blocks
    assert the_block_with("Client.connect") != the_block_with("bw4t.env")


def test_the_readme_agent_completes_a_match_alone(bw4t_bin: str, tmp_path: Path) -> None:
    (tmp_path / "agent.py").write_text(the_block_with("Client.connect"), encoding="utf-8")
    logs = tmp_path / "logs"
    argv = [
        bw4t_bin, "run", "--map", "fixed", "--robots", "1", "--seed", "5",
        "--agent", f"{shlex.quote(sys.executable)} agent.py", "--json", "--log-dir", str(logs),
    ]
    proc = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    log = "\n".join(p.read_text() for p in logs.glob("*.log"))
    assert proc.returncode == 0, f"{proc.stderr}\n{log}"
    result = json.loads(proc.stdout)
    assert result["completed"] and result["wrong_drops"] == 0, result
    assert [a["status"] for a in result["agents"]] == ["ok"], result["agents"]
    assert "Traceback" not in log, log  # it ends quietly when the match does
    assert "match over: completed" in log, log


def test_the_readme_training_snippet_runs(tmp_path: Path) -> None:
    (tmp_path / "train.py").write_text(the_block_with("bw4t.env"), encoding="utf-8")
    proc = subprocess.run(
        [sys.executable, "train.py"], cwd=tmp_path, capture_output=True, text=True, timeout=120,
        stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 0, proc.stderr
