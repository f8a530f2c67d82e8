#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The core's layer rule (ctest rules_layers): every #include of a core
source or header points to its own layer or one below it, in the order of
firmware/core/layers.txt.

    check_layers.py TABLE CORE                  check every file of the core
    check_layers.py TABLE CORE --file F --layer L
                                                check F as a file of layer L

CORE is firmware/core: src/<layer>/ holds the sources and private headers
(included as "<layer>/name.h"), include/sp/<layer>/ the public headers
(included as "sp/<layer>/name.h"). Also a failure: a file outside the
layer folders, a folder the table does not name, an include that names no
file of the core, the table or a generated header, and the umbrella header
included from the core, and a public header that the umbrella header
(include/sp/sp.h) does not include. Prints one line per problem; exit status 1 if any.
"""
import argparse
import pathlib
import re
import sys

INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"')


def read_table(path):
    """(layers lowest first, {generated header: layer}, umbrella header)."""
    layers, generated, umbrella = [], {}, None
    for line in pathlib.Path(path).read_text().splitlines():
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if words[0] == "layer":
            layers.append(words[1])
        elif words[0] == "generated":
            generated[words[1]] = words[2]
        elif words[0] == "umbrella":
            umbrella = words[1]
        else:
            raise SystemExit(f"{path}: unknown line: {line}")
    for name, layer in generated.items():
        if layer not in layers:
            raise SystemExit(f"{path}: generated {name}: no layer {layer}")
    return layers, generated, umbrella


def target_layer(core, include, generated):
    """The layer of an included file, or None when it names none."""
    parts = include.split("/")
    if parts[0] == "sp" and len(parts) == 3 and (core / "include" / include).is_file():
        return parts[1]
    if len(parts) == 2 and (core / "src" / include).is_file():
        return parts[0]
    return generated.get(include)


def check_file(core, path, layer, table):
    """The problems of one file of `layer` (a list of lines)."""
    layers, generated, umbrella = table
    rank = {name: i for i, name in enumerate(layers)}
    problems = []
    for n, line in enumerate(pathlib.Path(path).read_text().splitlines(), 1):
        m = INCLUDE.match(line)
        if not m:
            continue
        include = m.group(1)
        where = f"{path}:{n}: {layer}"
        if include == f"sp/{umbrella}":
            problems.append(f"{where}: includes the umbrella header {include}")
            continue
        to = target_layer(core, include, generated)
        if to is None or to not in rank:
            problems.append(f'{where}: "{include}" is no header of a core layer')
        elif rank[to] > rank[layer]:
            problems.append(f'{where}: upward include "{include}" (layer {to})')
    return problems


def core_files(core, table):
    """(path, layer) of every core source and header, and the problems of
    the tree itself (files outside a layer, folders the table lacks)."""
    layers, _, umbrella = table
    files, problems = [], []
    for base in (core / "src", core / "include" / "sp"):
        for path in sorted(base.rglob("*")):
            rel = path.relative_to(base)
            if path.is_dir():
                if len(rel.parts) > 1 or rel.parts[0] not in layers:
                    problems.append(f"{path}: a folder that is no layer of the table")
            elif path.suffix in (".c", ".h"):
                if len(rel.parts) == 2 and rel.parts[0] in layers:
                    files.append((path, rel.parts[0]))
                elif not (base.name == "sp" and rel.parts == (umbrella,)):
                    problems.append(f"{path}: outside the layer folders")
    if len(files) < 40:
        problems.append(f"{core}: only {len(files)} core files found: wrong root?")
    return files, problems


def umbrella_problems(core, files, umbrella):
    """Public headers that the umbrella header does not include."""
    path = core / "include" / "sp" / umbrella
    if not path.is_file():
        return [f"{path}: the umbrella header is missing"]
    text = path.read_text()
    return [
        f"{path}: does not include sp/{layer}/{f.name}"
        for f, layer in files
        if f.suffix == ".h" and f.parent.parent.name == "sp" and f'#include "sp/{layer}/{f.name}"' not in text
    ]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table")
    ap.add_argument("core")
    ap.add_argument("--file", help="check this file alone ...")
    ap.add_argument("--layer", help="... as a file of this layer")
    args = ap.parse_args(argv)
    table = read_table(args.table)
    core = pathlib.Path(args.core)
    if args.file:
        if args.layer not in table[0]:
            raise SystemExit(f"--layer {args.layer}: not a layer of {args.table}")
        files, problems = [(pathlib.Path(args.file), args.layer)], []
    else:
        files, problems = core_files(core, table)
        problems += umbrella_problems(core, files, table[2])
    for path, layer in files:
        problems += check_file(core, path, layer, table)
    for p in problems:
        print(p)
    if problems:
        return 1
    print(f"layers: {len(files)} files, every include points to its own layer or below")
    return 0


if __name__ == "__main__":
    sys.exit(main())
