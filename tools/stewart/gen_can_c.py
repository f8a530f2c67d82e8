"""Generates the firmware's CAN pack/unpack C code from the DBC.

    python3 tools/stewart/gen_can_c.py CANTOOLS protocol/stewart.dbc OUTDIR

Runs ``cantools generate_c_source --no-floating-point-numbers``. cantools
45.1 still emits ``*_is_in_phys_range(double)`` helpers with that option;
the firmware core may not contain floating point, so this removes exactly
those functions (prototype with its comment, and definition) and then fails
if any ``double`` or ``float`` is left, rather than letting it through.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

NAME = "stewart_can"


def strip_phys_range(text: str) -> str:
    # definitions: "bool name_is_in_phys_range(double value)\n{ ... }\n"
    text = re.sub(r"\nbool \w+_is_in_phys_range\(double value\)\n\{\n.*?\n\}\n", "\n", text, flags=re.S)
    # prototypes with their doc comment
    text = re.sub(r"\n/\*\*(?:(?!\*/).)*?\*/\nbool \w+_is_in_phys_range\(double value\);\n", "\n", text,
                  flags=re.S)
    return text


def main(argv: list[str]) -> int:
    if len(argv) != 3:
        print("usage: gen_can_c.py CANTOOLS DBC OUTDIR", file=sys.stderr)
        return 2
    cantools, dbc, out = argv
    outdir = Path(out)
    outdir.mkdir(parents=True, exist_ok=True)
    r = subprocess.run([cantools, "generate_c_source", "--no-floating-point-numbers", "--database-name", NAME,
                        "--output-directory", str(outdir), dbc], capture_output=True, text=True)
    if r.returncode != 0:
        print(r.stdout + r.stderr, file=sys.stderr)
        return 1
    for suffix in (".h", ".c"):
        p = outdir / (NAME + suffix)
        text = strip_phys_range(p.read_text())
        code = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
        bad = re.search(r"\b(double|float)\b", code)
        if bad:
            line = code[: bad.start()].count("\n") + 1
            print(f"error: {p}: floating point left in generated code near line {line}", file=sys.stderr)
            return 1
        p.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
