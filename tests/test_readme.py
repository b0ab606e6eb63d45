"""The README's code runs as written: its "Writing a node" snippet, pasted into a file."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from quadmission.examples import TalkerParams
from runtime.parameters import load_parameters

ROOT = Path(__file__).resolve().parents[1]


def _snippet(section: str) -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index(f"## {section}\n")
    end = text.find("\n## ", start + 1)
    block = re.search(r"```python\n(.*?)```", text[start:end], re.S)
    assert block, f"no python block under '## {section}'"
    return block.group(1)


def test_the_writing_a_node_snippet_runs_when_pasted(tmp_path: Path) -> None:
    script = tmp_path / "talker.py"
    script.write_text(_snippet("Writing a node"), encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}  # this checkout, as an installed package
    env.pop("QUADMISSION_CONFIG_DIR", None)
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    rate_hz = load_parameters(TalkerParams, "talker").rate_hz  # config/talker.yaml
    assert done.stdout.strip() == f"the listener heard {round(2.0 * rate_hz)} messages"
