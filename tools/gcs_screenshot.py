"""The README's picture of the operator page during a flight (docs/gcs_page.png).

    python tools/gcs_screenshot.py [--out docs/gcs_page.png] [--rtf 2]

Runs ``quadmission sim --scenario square --gcs --port 0`` as a user would, opens the page
it prints in Debian's headless chromium (Playwright), and takes the picture when the
square's third leg is being flown.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from playwright.sync_api import sync_playwright

CHROMIUM = "/usr/bin/chromium"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/gcs_page.png"))
    parser.add_argument("--rtf", type=float, default=2.0)
    parser.add_argument("--when", default="corner 3/4", help="progress text to wait for")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        proc = subprocess.Popen(
            [sys.executable, "-m", "quadmission.cli", "sim", "--scenario", "square", "--gcs",
             "--port", "0", "--rtf", str(args.rtf), "--out", tmp],
            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
        assert proc.stderr is not None
        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=CHROMIUM, headless=True,
                                            args=["--no-sandbox"])
                page = browser.new_page(viewport={"width": 1600, "height": 820})
                for line in proc.stderr:
                    found = re.search(r"ground station: (\S+)", line)
                    if found:
                        page.goto(found.group(1))
                    if args.when in line:
                        page.wait_for_timeout(3000)
                        args.out.parent.mkdir(parents=True, exist_ok=True)
                        page.screenshot(path=str(args.out))
                        print(f"wrote {args.out}")
                        break
                browser.close()
        finally:
            proc.kill()
            proc.wait()


if __name__ == "__main__":
    main()
