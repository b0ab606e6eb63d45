"""The docs hold: their code runs, their links land, the paths they name exist.

Every ```python block in README.md and docs/*.md runs as a script in a fresh process, unless
the line before its fence is ``<!-- not run: <reason> -->`` (a block importing ROS 2 packages
skips, naming the set-up, in a venv without the ROS 2 build; never under ``make test``).
Every relative link resolves to a file, and its #anchor to a heading of that file. Every
repository path written in backticks, inline or in a fenced block (``navigation/astar.py``,
``config/launch/square.yaml``), exists, and so does every file the architecture page's
Layout lists under its folder, so a moved module cannot leave the docs pointing at nothing.
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


TOPS = {p.name for p in ROOT.iterdir() if p.is_dir() and not p.name.startswith(".")}
TOPS -= {"runs", "mutants", "build"}  # outputs, not sources


def _code_lines(page: Path) -> list[tuple[int, str]]:
    """(line, code) for every line of a fenced block and every inline code span."""
    found, fenced = [], False
    for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif fenced:
            found.append((number, line))
        else:
            found += [(number, code) for code in CODE.findall(line)]
    return found


def repository_paths() -> list[tuple[str, int, str]]:
    """(page, line, path) for every word in code that starts with a top-level folder of
    the repository; examples (``<name>``, ``*``, ``...``) and outputs (``runs/``) left out."""
    found = []
    for page in PAGES:
        for number, code in _code_lines(page):
            for word in code.split():
                word = word.split(":")[0].strip("`'\"(),;.")
                if ("/" in word and word.split("/")[0] in TOPS
                        and not re.search(r"[<*{$]|\.\.\.", word)):
                    found.append((_name(page), number, word))
    return found


def test_every_repository_path_the_docs_name_exists() -> None:
    paths = repository_paths()
    missing = [f"{page}:{line}: {path}" for page, line, path in paths
               if not (ROOT / path).exists()]
    assert len(paths) > 50, "the path collector found too few paths"
    assert not missing, "the docs name paths that do not exist:\n" + "\n".join(missing)


LAYOUT_TOKEN = re.compile(r"[()]|[\w./+-]+")
LAYOUT_FILE = re.compile(r"[\w./-]+\.(py|yaml|xml|md|json)")


def layout_paths(text: str) -> list[tuple[int, str]]:
    """(line, path) for every folder (``name/``) and file (``name.py``) the Layout block
    of the architecture page lists. An entry starts at the line's first column with its
    folder; ``sub/ (a.py, b.py)`` lists a.py and b.py in sub/; a path with a slash inside
    is read from the entry's folder, else from the repository's root."""
    heading = text.index("\n## Layout\n")
    start = text.index("```\n", heading) + 4
    first = text.count("\n", 0, start) + 1
    found: list[tuple[int, str]] = []
    stack: list[str] = []
    for number, line in enumerate(text[start:text.index("```", start)].splitlines(), first):
        if line[:1].strip():  # a new entry: its folder
            top = line.split()[0]
            found.append((number, top))
            stack, words = [top], line.split(None, 1)[1:]
            line = words[0] if words else ""
        folder = None  # the folder just named, which a "(" opens
        for token in LAYOUT_TOKEN.findall(line):
            if token == "(":
                stack.append(folder or stack[-1])
            elif token == ")":
                stack.pop()
            elif token.endswith("/") or LAYOUT_FILE.fullmatch(token):
                path = stack[-1] + token
                if "/" in token.rstrip("/") and not (ROOT / path).exists():
                    path = token
                found.append((number, path))
            folder = stack[-1] + token if token.endswith("/") else None
    return found


def test_every_file_the_architecture_layout_lists_exists() -> None:
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    listed = layout_paths(text)
    missing = [f"docs/architecture.md:{line}: {path}" for line, path in listed
               if not (ROOT / path).exists()]
    assert len(listed) > 80, f"the Layout parser found only {len(listed)} paths"
    assert not missing, ("the Layout of docs/architecture.md lists paths that do not "
                         "exist:\n" + "\n".join(missing))


def test_the_layout_parser_reads_nested_folders_and_flags_a_missing_file() -> None:
    text = ("# Page\n## Layout\n\n```\nsim/            world.py, fcu/ (link.py,\n"
            "                no_such.py), docs/results.md\n```\n")
    assert layout_paths(text) == [(5, "sim/"), (5, "sim/world.py"), (5, "sim/fcu/"),
                                  (5, "sim/fcu/link.py"), (6, "sim/fcu/no_such.py"),
                                  (6, "docs/results.md")]


def test_the_readme_is_a_short_front_door() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").count("\n")
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines; move detail to docs/"
