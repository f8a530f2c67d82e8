# SPDX-License-Identifier: Apache-2.0
"""Every relative link in README.md and docs/**/*.md points at a file that
exists, and a link's #anchor into a Markdown page names one of its
headings (GitHub's heading ids). The README starts with the two commands
and stays short; README and docs carry no work-log notes (history goes to
CHANGELOG.md)."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^\s*(```|~~~)")
EXTERNAL = ("http://", "https://", "mailto:")
#: work-log words, and the name of a notes file outside the project (built so
#: that this file does not name it)
OUTSIDE_NOTES = "NOTES" + r"\.md"
WORK_LOG = re.compile(r"session [0-9]|next session|issue [0-9]|" + OUTSIDE_NOTES, re.IGNORECASE)
README_START = "# Stewart platform motion controller\n\n```\n./scripts/demo.sh\n./scripts/test.sh\n```\n"
README_MAX_LINES = 250


def heading_ids(text: str) -> set[str]:
    """The anchors GitHub gives a page's headings: lower case, punctuation
    other than '-' and '_' dropped, spaces to '-', repeats numbered."""
    ids, seen = set(), {}
    in_code = False
    for line in text.splitlines():
        if FENCE.match(line):
            in_code = not in_code
            continue
        m = None if in_code else re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        slug = re.sub(r"[^\w\- ]", "", m.group(1).lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        ids.add(slug if n == 0 else f"{slug}-{n}")
    return ids


def links(text: str):
    """(line number, target) of every Markdown link outside code blocks."""
    in_code = False
    for no, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            in_code = not in_code
            continue
        if not in_code:
            for m in LINK.finditer(re.sub(r"`[^`]*`", "", line)):
                yield no, m.group(1)


def broken_links(page: Path) -> list[str]:
    """The broken relative links of one page, as 'page:line: target'."""
    bad = []
    for no, target in links(page.read_text(encoding="utf-8")):
        if target.startswith(EXTERNAL):
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        ok = dest.exists()
        if ok and anchor and dest.suffix == ".md":
            ok = anchor in heading_ids(dest.read_text(encoding="utf-8"))
        if not ok:
            bad.append(f"{page.relative_to(ROOT) if page.is_relative_to(ROOT) else page}:{no}: {target}")
    return bad


def pages() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def test_every_relative_link_resolves():
    bad = [b for p in pages() for b in broken_links(p)]
    assert not bad, "broken links:\n" + "\n".join(bad)


def test_the_checker_finds_broken_links(tmp_path):
    """Positive control: a missing file, a missing anchor and a missing
    image are reported; a good file, anchor, image, external link and a
    link inside code are not."""
    (tmp_path / "img.png").write_bytes(b"")
    (tmp_path / "other.md").write_text("# Other page\n\n## The `sp/x.h` part (one)\n")
    page = tmp_path / "page.md"
    page.write_text(
        "# Page\n"
        "[good](other.md) [anchor](other.md#the-spxh-part-one) [self](#page)\n"
        "![image](img.png) [web](https://example.org/x)\n"
        "```\n[in code](missing_in_code.md)\n```\n"
        "`[inline](missing_inline.md)`\n"
        "[gone](missing.md)\n"
        "[bad anchor](other.md#nowhere)\n"
        "![no image](nothing.png)\n")
    bad = broken_links(page)
    assert [b.split(": ", 1)[1] for b in bad] == ["missing.md", "other.md#nowhere", "nothing.png"]
    assert [b.split(":")[-2] for b in bad] == ["8", "9", "10"]


def test_pages_cover_readme_and_nested_docs():
    found = {p.relative_to(ROOT).as_posix() for p in pages()}
    assert "README.md" in found
    assert any(p.count("/") >= 2 for p in found), "docs/ subfolders are searched"


def work_log_notes(page: Path) -> list[str]:
    """'page:line: text' of each line that reads like a work log."""
    return [f"{page.name}:{no}: {line.strip()}"
            for no, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1)
            if WORK_LOG.search(line)]


def test_readme_starts_with_the_two_commands_and_is_short():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert text.startswith(README_START)
    assert len(text.splitlines()) <= README_MAX_LINES


def test_no_work_log_notes_in_readme_or_docs(tmp_path):
    bad = [b for p in pages() for b in work_log_notes(p)]
    assert not bad, "history belongs in CHANGELOG.md:\n" + "\n".join(bad)
    page = tmp_path / "p.md"
    page.write_text("fine\nas in Session 12\nthe --session 1 option\nsee " + "NOTES" + ".md\nissue 14's bound\n")
    assert [b.split(":")[1] for b in work_log_notes(page)] == ["2", "3", "4", "5"]
