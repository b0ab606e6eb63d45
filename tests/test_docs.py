"""The docs hold: their code runs, their links land, the paths they name exist.

Every ```python block in README.md and docs/*.md runs as a script in a fresh process, unless
the line before its fence is ``<!-- not run: <reason> -->`` (a block importing ROS 2 packages
skips, naming the set-up, in a venv without the ROS 2 build; never under ``make test``).
Every relative link resolves to a file, and its #anchor to a heading of that file. Every
repository path written in backticks (``navigation/astar.py``,
``config/launch/square.yaml``) exists, so a moved module cannot leave the docs pointing at
nothing.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
README_MAX_LINES = 250  # the front door stays short; the rest goes to docs/

FENCE = re.compile(r"^```python\n(.*?)^```", re.M | re.S)
NOT_RUN = re.compile(r"<!-- not run: (?P<reason>\S.*?) -->\n$")
ROS2_IMPORT = re.compile(r"^\s*(from|import) (rclpy|px4_msgs|quadmission_interfaces)\b", re.M)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
CODE = re.compile(r"`([^`\n]+)`")


def _name(path: Path) -> str:
    return str(path.relative_to(ROOT))


def python_blocks() -> list[tuple[str, int, str, str | None]]:
    """(page, line, code, reason it is not run or None) for every python block."""
    blocks = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for match in FENCE.finditer(text):
            before = text[:match.start()]
            line = before.count("\n") + 1
            previous = before.rsplit("\n", 2)[-2] + "\n" if before.count("\n") >= 1 else ""
            skip = NOT_RUN.match(previous)
            blocks.append((_name(page), line, match.group(1), skip and skip["reason"]))
    return blocks


BLOCKS = python_blocks()


def test_the_pages_have_python_blocks_to_run() -> None:
    assert sum(reason is None for *_, reason in BLOCKS) >= 1, "the block collector found nothing"


@pytest.mark.parametrize(("page", "line", "code", "not_run"), BLOCKS,
                         ids=[f"{page}:{line}" for page, line, *_ in BLOCKS])
def test_every_python_block_runs_as_written(page: str, line: int, code: str,
                                            not_run: str | None, tmp_path: Path) -> None:
    if not_run is not None:
        pytest.skip(f"{page}:{line} is marked not run: {not_run}")
    from runtime.ros2.config import SETUP_HINT, missing_modules

    if ROS2_IMPORT.search(code) and missing_modules():
        pytest.skip(f"{page}:{line} imports ROS 2 packages that are not built: {SETUP_HINT}")
    script = tmp_path / "block.py"
    script.write_text(code, encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}  # this checkout, as an installed package
    env.pop("QUADMISSION_CONFIG_DIR", None)
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, f"the block at {page}:{line} fails:\n{done.stderr}"


def anchors(page: Path) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"^```.*?^```", "", page.read_text(encoding="utf-8"), flags=re.M | re.S)
    found = set()
    for heading in re.findall(r"^#{1,6} (.+)$", text, re.M):
        kept = "".join(ch for ch in heading.strip().lower() if ch.isalnum() or ch in " -_")
        found.add(kept.replace(" ", "-"))
    return found


def relative_links() -> list[tuple[str, str]]:
    links = []
    for page in PAGES:
        text = re.sub(r"^```.*?^```", "", page.read_text(encoding="utf-8"), flags=re.M | re.S)
        links += [(_name(page), target) for target in LINK.findall(text)
                  if not re.match(r"[a-z]+:", target)]
    return links


def test_every_relative_link_lands_on_a_file_and_a_heading() -> None:
    broken = []
    for page, target in relative_links():
        path_part, _, anchor = target.partition("#")
        file = (ROOT / page).parent / path_part if path_part else ROOT / page
        if not file.exists():
            broken.append(f"{page}: {target} (no such file)")
        elif anchor and file.suffix == ".md" and anchor not in anchors(file):
            broken.append(f"{page}: {target} (no heading #{anchor} in {_name(file.resolve())})")
    assert len(relative_links()) > 20, "the link collector found too few links"
    assert not broken, "broken links:\n" + "\n".join(broken)


def repository_paths() -> list[tuple[str, str]]:
    """Words in backticks that start with one of the repository's top-level folders."""
    tops = {p.name for p in ROOT.iterdir() if p.is_dir() and not p.name.startswith(".")}
    tops -= {"runs", "mutants", "build"}  # outputs, not sources
    found = []
    for page in PAGES:
        for code in CODE.findall(page.read_text(encoding="utf-8")):
            for word in code.split():
                word = word.split(":")[0].rstrip(",;)")
                if "/" in word and word.split("/")[0] in tops and not re.search(r"[<*]|\.\.\.",
                                                                                  word):
                    found.append((_name(page), word))
    return found


def test_every_repository_path_the_docs_name_exists() -> None:
    paths = repository_paths()
    missing = sorted({f"{page}: {path}" for page, path in paths if not (ROOT / path).exists()})
    assert len(paths) > 50, "the path collector found too few paths"
    assert not missing, "the docs name paths that do not exist:\n" + "\n".join(missing)


def test_the_readme_is_a_short_front_door() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").count("\n")
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines; move detail to docs/"
