# SPDX-License-Identifier: Apache-2.0
"""No function over 80 lines in firmware/, host_sim/ and tools/.

How a function is measured:

* C (``*.c``, ``*.h`` under firmware/ and host_sim/): from the line of the
  function body's opening brace to the line of its closing brace, both
  included. The scanner blanks comments, string and character literals and
  preprocessor lines (with their continuations), then takes every brace at
  file level that follows a closing parenthesis as a function body; the
  name is the identifier before the matching opening parenthesis.
* Python (``*.py`` under tools/): from the ``def`` line to the function's
  last line (``ast``'s ``lineno`` .. ``end_lineno``), both included;
  decorators are not counted, the docstring is. Methods are named
  ``Class.method``; a nested function is measured on its own and also
  counts in the lines of the function around it.

Python functions over the limit always fail. A C function over it fails
unless tests/rules/long_functions.txt lists it, either as one of at most
three measured hot paths of the core (firmware/core/), or in the TODO-split
section of functions waiting for their split. A hot path's entry names its
plain reference in the tests (``ref=name``, found in a C file under tests/)
and a reason, and the comment above the function gives the instruction cost
of splitting it (it says "instruction"). An entry that no longer names a
function over the limit fails too, so the list can only shrink.
``pytest -s`` prints the longest functions.
"""

import ast
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parents[2]
LIMIT = 80
MAX_HOT_PATHS = 3
ALLOW_FILE = ROOT / "tests" / "rules" / "long_functions.txt"
HOT_SECTION = "hot-path"
PENDING_SECTION = "TODO-split"


@dataclass(frozen=True)
class Function:
    path: str  # relative to the root, with forward slashes
    name: str
    first: int  # 1-based line numbers, both included
    last: int

    @property
    def lines(self) -> int:
        return self.last - self.first + 1

    @property
    def key(self) -> str:
        """How long_functions.txt names it: file name and function, so
        that moving the file to another folder keeps the entry."""
        return f"{Path(self.path).name}:{self.name}"


# --- C ---------------------------------------------------------------------

_C_TOKEN = re.compile(r"""
    (?P<comment>/\*.*?\*/|//[^\n]*)
  | (?P<string>"(?:\\.|[^"\\\n])*"|'(?:\\.|[^'\\\n])*')
""", re.S | re.X)


def _blank(match: re.Match) -> str:
    """The match with everything but its newlines turned into spaces."""
    return re.sub(r"[^\n]", " ", match.group(0))


def _blank_preprocessor(text: str) -> str:
    """``text`` with every preprocessor line (and its backslash
    continuations) blanked, line count kept."""
    out = []
    in_directive = False
    for line in text.split("\n"):
        if in_directive or line.lstrip().startswith("#"):
            in_directive = line.rstrip().endswith("\\")
            out.append("")
        else:
            out.append(line)
    return "\n".join(out)


def c_code_only(text: str) -> str:
    """C source with comments, literals and preprocessor lines blanked;
    every character that is kept stays on its line."""
    return _blank_preprocessor(_C_TOKEN.sub(_blank, text))


def c_functions(text: str, path: str = "<text>") -> list[Function]:
    """Every function definition in the C source ``text``."""
    code = c_code_only(text)
    found = []
    depth = 0
    parens: list[int] = []  # offsets of the open parentheses at file level
    last_paren_open = None  # offset of the '(' matching the last ')'
    significant = ""  # last non-blank character seen at file level
    body_start = None
    for i, ch in enumerate(code):
        if ch.isspace():
            continue
        if depth == 0:
            if ch == "(":
                parens.append(i)
            elif ch == ")" and parens:
                last_paren_open = parens.pop()
            elif ch == "{":
                if significant == ")" and not parens and last_paren_open is not None:
                    body_start = i
                else:
                    body_start = None
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
            if depth == 0 and body_start is not None:
                name = re.search(r"(\w+)\s*$", code[:last_paren_open])
                found.append(Function(path, name.group(1) if name else "?",
                                      code.count("\n", 0, body_start) + 1,
                                      code.count("\n", 0, i) + 1))
                body_start = None
        if depth == 0:
            significant = ch
    return found


# --- Python ----------------------------------------------------------------

def py_functions(text: str, path: str = "<text>") -> list[Function]:
    """Every function and method in the Python source ``text``."""
    found = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = prefix + child.name
                found.append(Function(path, name, child.lineno, child.end_lineno))
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(text), "")
    return found


# --- the project -----------------------------------------------------------

def _sources(folder: str, suffixes: tuple[str, ...]) -> list[Path]:
    return sorted(p for p in (ROOT / folder).rglob("*")
                  if p.suffix in suffixes and p.is_file()
                  and not any(part.startswith((".", "__pycache__"))
                              for part in p.relative_to(ROOT).parts))


def project_functions() -> tuple[list[Function], list[Function]]:
    """The C functions of firmware/ and host_sim/, the Python ones of tools/."""
    c_funcs = []
    for folder in ("firmware", "host_sim"):
        for p in _sources(folder, (".c", ".h")):
            rel = p.relative_to(ROOT).as_posix()
            c_funcs += c_functions(p.read_text(errors="replace"), rel)
    py_funcs = []
    for p in _sources("tools", (".py",)):
        rel = p.relative_to(ROOT).as_posix()
        py_funcs += py_functions(p.read_text(), rel)
    return c_funcs, py_funcs


def read_allow_list(text: str) -> dict[str, dict[str, str]]:
    """The sections of long_functions.txt: {section: {key: reason}}.
    A line is ``[section]``, a comment (``#``), blank, or
    ``file.c:function  reason``."""
    sections: dict[str, dict[str, str]] = {}
    current = None
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        header = re.fullmatch(r"\[(.+)\]", line)
        if header:
            current = sections.setdefault(header.group(1), {})
            continue
        if current is None:
            raise ValueError(f"line {number}: entry before any [section]")
        key, _, reason = line.partition(" ")
        current[key] = reason.strip()
    return sections


def check(c_funcs: list[Function], py_funcs: list[Function],
          allowed: dict[str, dict[str, str]]) -> list[str]:
    """Every breach of the rule, one message each."""
    hot = allowed.get(HOT_SECTION, {})
    pending = allowed.get(PENDING_SECTION, {})
    problems = [f"{f.path}: {f.name} has {f.lines} lines (limit {LIMIT})"
                for f in py_funcs if f.lines > LIMIT]
    problems += [f"{f.path}: {f.name} has {f.lines} lines (limit {LIMIT}); split it"
                 for f in c_funcs
                 if f.lines > LIMIT and f.key not in hot and f.key not in pending]
    return problems


def _comment_above(func: Function, funcs: list[Function], text: str) -> str:
    """The lines between the function before ``func`` in its file (or the
    file's start) and ``func``'s body: its signature and comment."""
    before = [f.last for f in funcs if f.path == func.path and f.last < func.first]
    return "\n".join(text.splitlines()[max(before, default=0):func.first])


def check_allow_list(c_funcs: list[Function], allowed: dict[str, dict[str, str]],
                     read: Callable[[str], str], tests_text: str) -> list[str]:
    """What is wrong with the allow-list itself. ``read`` gives a source
    file's text by its path, ``tests_text`` is the text of the tests, where
    each hot path's plain reference must be."""
    unknown = set(allowed) - {HOT_SECTION, PENDING_SECTION}
    problems = [f"unknown section [{s}]" for s in sorted(unknown)]
    hot = allowed.get(HOT_SECTION, {})
    if len(hot) > MAX_HOT_PATHS:
        problems.append(f"{len(hot)} hot paths listed, at most {MAX_HOT_PATHS}")
    long_ones = {f.key: f for f in c_funcs if f.lines > LIMIT}
    for key, reason in hot.items():
        ref = re.search(r"\bref=(\w+)", reason)
        if not ref or not reason.replace(ref.group(0), "").strip():
            problems.append(f"hot path {key} must give ref=<plain reference> and a reason")
        elif not re.search(rf"\b{ref.group(1)}\b", tests_text):
            problems.append(f"hot path {key}: its reference {ref.group(1)} is not in tests/")
        func = long_ones.get(key)
        if func is None:
            continue
        if not func.path.startswith("firmware/core/"):
            problems.append(f"hot path {key} is not in the core (firmware/core/)")
        if "instruction" not in _comment_above(func, c_funcs, read(func.path)).lower():
            problems.append(f"hot path {key} has no comment above it giving the "
                            "instruction cost of splitting it")
    for section in (HOT_SECTION, PENDING_SECTION):
        for key in allowed.get(section, {}):
            if key not in long_ones:
                problems.append(f"[{section}] {key} is not a C function over {LIMIT} "
                                "lines (any more): remove the entry")
    return problems


def longest_table(funcs: list[Function], count: int = 25) -> str:
    rows = sorted(funcs, key=lambda f: (-f.lines, f.path, f.name))[:count]
    return "\n".join(f"{f.lines:5d}  {f.path}: {f.name}" for f in rows)


# --- the tests -------------------------------------------------------------

def test_no_function_over_the_limit():
    c_funcs, py_funcs = project_functions()
    assert len(c_funcs) > 300 and len(py_funcs) > 300  # the scan found the code
    print(f"\nthe longest functions (limit {LIMIT} lines):\n{longest_table(c_funcs + py_funcs)}")
    problems = check(c_funcs, py_funcs, read_allow_list(ALLOW_FILE.read_text()))
    assert problems == [], "functions over the limit:\n" + "\n".join(problems)


def test_the_allow_list_is_small_and_current():
    c_funcs, _ = project_functions()
    tests_text = "\n".join(p.read_text(errors="replace") for p in _sources("tests", (".c", ".h")))
    problems = check_allow_list(c_funcs, read_allow_list(ALLOW_FILE.read_text()),
                                lambda path: (ROOT / path).read_text(errors="replace"), tests_text)
    assert problems == [], "\n".join(problems)


# --- the checks on fixtures ------------------------------------------------

def _c_function(name: str, body_lines: int) -> str:
    body = "".join(f"    x += {k};\n" for k in range(body_lines))
    return f"static int {name}(int x)\n{{\n{body}    return x;\n}}\n"


def _py_function(name: str, body_lines: int) -> str:
    body = "".join(f"    x += {k}\n" for k in range(body_lines))
    return f"@decorated\ndef {name}(x):\n{body}    return x\n"


C_FIXTURE = (
    "/* a comment with a brace { and a call f(x) { */\n"
    "#define BLOCK(x) { (x); }\n"
    "#if defined(A) \\\n    && defined(B) {\n#endif\n"
    "struct pair { int a; int b; };\n"
    "static const int table[] = {1, 2, 3};\n"
    + _c_function("short_one", 10)
    + "static const char *text(void)\n{\n    return \"} {\";\n}\n"
    + _c_function("long_one", 80)  # 80 + 3 lines from brace to brace
)

PY_FIXTURE = (
    '"""A module."""\n'
    + _py_function("short_one", 10)
    + "class Holder:\n"
    + "".join("    " + line + "\n" for line in _py_function("long_one", 79).splitlines())
)


def test_c_functions_are_found_and_measured():
    funcs = {f.name: f for f in c_functions(C_FIXTURE, "firmware/core/src/x.c")}
    assert set(funcs) == {"short_one", "text", "long_one"}
    assert funcs["short_one"].lines == 10 + 3
    assert funcs["text"].lines == 3
    assert funcs["long_one"].lines == 83
    first = C_FIXTURE.splitlines()[funcs["long_one"].first - 1]
    assert first == "{"


def test_python_functions_are_found_and_measured():
    funcs = {f.name: f for f in py_functions(PY_FIXTURE, "tools/x.py")}
    assert set(funcs) == {"short_one", "Holder.long_one"}
    assert funcs["short_one"].lines == 10 + 2  # def and return; no decorator
    assert funcs["Holder.long_one"].lines == 81


def test_the_rule_names_each_long_function():
    c_funcs = c_functions(C_FIXTURE, "host_sim/src/x.c")
    py_funcs = py_functions(PY_FIXTURE, "tools/x.py")
    problems = check(c_funcs, py_funcs, {})
    assert len(problems) == 2
    assert "tools/x.py: Holder.long_one has 81 lines" in problems[0]
    assert "host_sim/src/x.c: long_one has 83 lines" in problems[1]
    assert not any("short_one" in p for p in problems)


def test_the_allow_list_excuses_c_but_never_python():
    c_funcs = c_functions(C_FIXTURE, "firmware/core/src/x.c")
    py_funcs = py_functions(PY_FIXTURE, "tools/x.py")
    for section in (HOT_SECTION, PENDING_SECTION):
        allowed = read_allow_list(f"# comment\n[{section}]\nx.c:long_one  measured\n"
                                  f"[{PENDING_SECTION}]\nx.py:Holder.long_one  no\n")
        problems = check(c_funcs, py_funcs, allowed)
        assert len(problems) == 1 and "Holder.long_one" in problems[0]


def test_the_allow_list_is_checked():
    c_funcs = c_functions(C_FIXTURE, "host_sim/src/x.c")
    core = c_functions(C_FIXTURE, "firmware/core/src/x.c")
    with_cost = C_FIXTURE.replace("static int long_one", "/* 9 instructions more */\nstatic int long_one")
    core_cost = c_functions(with_cost, "firmware/core/src/x.c")
    tests_text = "void plain_long_one(void);"

    def problems(funcs, text, source=C_FIXTURE):
        return check_allow_list(funcs, read_allow_list(text), lambda _: source, tests_text)

    assert problems(c_funcs, f"[{HOT_SECTION}]\n[{PENDING_SECTION}]\nx.c:long_one\n") == []
    good_hot = f"[{HOT_SECTION}]\nx.c:long_one  ref=plain_long_one  measured: 9 instructions\n"
    assert problems(core_cost, good_hot, with_cost) == []
    assert problems(core, good_hot) == [
        "hot path x.c:long_one has no comment above it giving the instruction cost of splitting it"]
    bad = problems(c_funcs, f"[{HOT_SECTION}]\nx.c:long_one  fast\n"
                   + "".join(f"y{k}.c:f  ref=plain_long_one fast\n" for k in range(2))
                   + "z.c:f  ref=plain_other fast\n"
                   + f"[{PENDING_SECTION}]\nx.c:short_one\n[other]\n")
    assert "unknown section [other]" in bad
    assert f"4 hot paths listed, at most {MAX_HOT_PATHS}" in bad
    assert "hot path x.c:long_one must give ref=<plain reference> and a reason" in bad
    assert "hot path z.c:f: its reference plain_other is not in tests/" in bad
    assert "hot path x.c:long_one is not in the core (firmware/core/)" in bad
    assert any(p.startswith("[TODO-split] x.c:short_one is not") for p in bad)
    assert any(p.startswith("[hot-path] y0.c:f is not") for p in bad)
