"""Runs examples/notebook.ipynb in a kernel (as the test suite does) and
saves what its interactive view showed after the scripted drag: the image
in docs/notebook_view.png.

Run: .venv/bin/python tools/notebook_picture.py [docs/notebook_view.png]
"""

import base64
import io
import os
import re
import sys
import tempfile

import nbformat
from nbclient import NotebookClient

ROOT = os.path.join(os.path.dirname(__file__), "..")


def main(out):
    os.environ.setdefault("PYVR_DATA", os.path.join(ROOT, "..", "shared", "data"))
    nb = nbformat.read(os.path.join(ROOT, "examples", "notebook.ipynb"), as_version=4)
    with tempfile.TemporaryDirectory() as tmp:
        NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": tmp}}).execute()
    for cell in nb.cells:
        for o in cell.get("outputs", []):
            html = o.get("data", {}).get("text/html", "")
            m = re.search(r"base64,([^']+)'", html)
            if m and "snapshot" in html:
                from PIL import Image

                # jupyter_rfb sends snapshots as JPEG where it can; stored here as PNG.
                Image.open(io.BytesIO(base64.b64decode(m.group(1)))).save(out)
                print(f"wrote {out}")
                return
    raise SystemExit("the notebook showed no view snapshot")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "docs", "notebook_view.png"))
