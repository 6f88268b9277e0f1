"""Draw the gallery (docs/gallery/*.png) anew with ``jaxroll reproduce --quick`` and record where
and when in docs/gallery.md (the line between the ``generated: gallery-run`` markers).

    python docs/make_gallery.py

The figures are those of the current code; every figure marks the points that the method or the
reference flags invalid (a legend entry says so), as ``jaxroll reproduce`` draws them.
"""

import datetime
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GALLERY = ROOT / "docs" / "gallery"
PAGE = ROOT / "docs" / "gallery.md"


def main():
    names = sorted(p.name for p in GALLERY.glob("*.png"))
    with tempfile.TemporaryDirectory() as work:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "jaxroll.apps.cli", "reproduce", "--quick", "--quiet", "--out", work],
                       check=True, cwd=work)
        seconds = time.perf_counter() - t0
        missing = [n for n in names if not (Path(work) / n).exists()]
        if missing:
            raise SystemExit(f"reproduce --quick no longer draws {missing}: update docs/gallery.md")
        for n in names:
            shutil.copy(Path(work) / n, GALLERY / n)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=ROOT).stdout.strip()
    line = (f"Drawn by `python docs/make_gallery.py` (`jaxroll reproduce --quick`, {seconds:.0f} s) on "
            f"{datetime.date.today().isoformat()} at commit {commit}, {platform.machine()}.")
    text = PAGE.read_text()
    text = re.sub(r"(<!-- generated: gallery-run -->\n).*?(\n<!-- /generated: gallery-run -->)",
                  lambda m: m.group(1) + line + m.group(2), text, flags=re.S)
    PAGE.write_text(text)
    print(line)


if __name__ == "__main__":
    main()
