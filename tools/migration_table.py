"""Write the migration tables from docs/migration.toml.

    python tools/migration_table.py          # rewrite docs/migration.md and README's table
    python tools/migration_table.py --check  # exit 1 if either is out of date

docs/migration.md gets every change; the README, between its
``<!-- migration -->`` markers, the ones marked ``headline = true``.
"""

import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "docs" / "migration.toml"
PAGE = ROOT / "docs" / "migration.md"
README = ROOT / "README.md"
START, END = "<!-- migration -->", "<!-- /migration -->"

INTRO = """# Migrating from pyvr 0.4.1

Generated from [migration.toml](migration.toml) by `tools/migration_table.py`; edit that file.

Everything public in pyvr 0.4.1 keeps its module path, name, signature,
defaults, attributes, exception class, message text and repr, except where a row
below says otherwise: `tests/compat/test_pyvr041_surface.py` compares pyvr
with a record of pyvr 0.4.1's surface (`tests/compat/pyvr041_surface.json`,
derived from its source by `tools/pyvr041_surface.py`) and fails on any
difference that no row here accounts for. Behaviour changes where pyvr 0.4.1
was wrong, and where a capability could not carry over (OpenGL); names kept
only for compatibility are marked so in their docstrings.

"""


def cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def table(changes) -> str:
    rows = ["| pyvr 0.4.1 | now | why |", "|---|---|---|"]
    rows += [f"| {cell(c['was'])} | {cell(c['now'])} | {cell(c['why'])} |" for c in changes]
    return "\n".join(rows) + "\n"


def outputs() -> dict:
    changes = tomllib.loads(SOURCE.read_text())["change"]
    page = INTRO + table(changes)
    readme = README.read_text()
    head, rest = readme.split(START, 1)
    _, tail = rest.split(END, 1)
    readme = head + START + "\n" + table([c for c in changes if c.get("headline")]) + END + tail
    return {PAGE: page, README: readme}


def main() -> int:
    stale = [p for p, text in outputs().items() if not p.exists() or p.read_text() != text]
    if "--check" in sys.argv[1:]:
        for p in stale:
            print(f"{p.relative_to(ROOT)} is out of date: run python tools/migration_table.py")
        return 1 if stale else 0
    for p, text in outputs().items():
        p.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
