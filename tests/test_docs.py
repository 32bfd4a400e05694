"""The documentation holds together: every relative link in README.md, CONTRIBUTING.md and docs/*.md resolves
(the file exists; an anchor into a markdown file names one of its headings, slugged as GitHub does), the
README stays short, and no page speaks of how the work was organised (numbered sessions, lettered helpers,
issue numbers): that history is git's."""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README_MAX_LINES = 300

#: ``[text](target)`` and ``![alt](target)``; the target ends at the first space or closing parenthesis.
_LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_FENCE = re.compile(r"^(```|~~~)")
_HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
_FORBIDDEN = re.compile(r"\bsessions? [0-9]+|\bhelpers? [A-Z]\b|\bissues? #", re.IGNORECASE)


def doc_files() -> list[Path]:
    """README.md, CONTRIBUTING.md and every markdown file under docs/."""
    files = [ROOT / "README.md", ROOT / "CONTRIBUTING.md", *sorted((ROOT / "docs").glob("*.md"))]
    return [f for f in files if f.exists()]


def prose_lines(path: Path) -> list[tuple[int, str]]:
    """(line number, text) of the lines outside fenced code blocks."""
    out, fenced = [], False
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if _FENCE.match(line.lstrip()):
            fenced = not fenced
            continue
        if not fenced:
            out.append((number, line))
    return out


def _strip_code_spans(line: str) -> str:
    return re.sub(r"`[^`]*`", "", line)


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: markup dropped, lower case, punctuation removed, spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link keeps its text
    text = text.replace("`", "").replace("*", "")
    text = unicodedata.normalize("NFC", text).lower()
    text = "".join(c for c in text if c.isalnum() or c in " -_")
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every heading anchor of a markdown file, duplicates numbered (``-1``, ``-2``) as GitHub does."""
    seen: dict[str, int] = {}
    result = set()
    for _, line in prose_lines(path):
        m = _HEADING.match(line)
        if not m:
            continue
        base = slug(m.group(2))
        n = seen.get(base, 0)
        result.add(base if n == 0 else f"{base}-{n}")
        seen[base] = n + 1
    return result


def relative_links(path: Path) -> list[tuple[int, str]]:
    """(line number, target) of every link that is neither absolute (scheme, ``//``) nor a mail address."""
    found = []
    for number, line in prose_lines(path):
        for target in _LINK.findall(_strip_code_spans(line)):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.IGNORECASE) or target.startswith("//"):
                continue
            found.append((number, target))
    return found


def test_there_are_pages_to_check() -> None:
    names = {p.name for p in doc_files()}
    assert {"README.md", "CONTRIBUTING.md"} <= names
    assert len(names) >= 10


@pytest.mark.parametrize("path", doc_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(path: Path) -> None:
    broken = []
    for number, target in relative_links(path):
        file_part, _, anchor = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        where = f"{path.relative_to(ROOT)}:{number}: {target}"
        if not dest.exists():
            broken.append(f"{where}: no such file")
        elif anchor and dest.suffix.lower() == ".md" and anchor.lower() not in anchors(dest):
            broken.append(f"{where}: no heading with anchor '#{anchor}' in {dest.name}")
    assert not broken, "\n".join(broken)


def test_the_readme_is_short() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines (at most {README_MAX_LINES})"


@pytest.mark.parametrize("path", doc_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_page_speaks_of_how_the_work_was_organised(path: Path) -> None:
    hits = [f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
            if _FORBIDDEN.search(line)]
    assert not hits, "\n".join(hits)


def test_the_checks_themselves() -> None:
    assert slug("The camera: `--camera FILE` (a projection matrix)") == "the-camera---camera-file-a-projection-matrix"
    assert slug("Set-up: two commands") == "set-up-two-commands"
    assert slug("Is this machine ready? `sheer doctor`") == "is-this-machine-ready-sheer-doctor"
    numbered, lettered = "session" + " 7", "helper" + " A"  # split so that this file itself stays clean
    assert _FORBIDDEN.search(f"after {numbered} the") and _FORBIDDEN.search(f"{lettered}'s run")
    assert _FORBIDDEN.search("see issue #15") and not _FORBIDDEN.search("the shopper's session ends")
    assert not _FORBIDDEN.search("the helper function") and not _FORBIDDEN.search("a session of 3 minutes")
    links = _LINK.findall("see [a](docs/A.md#x), ![img](docs/images/b.png) and [c](https://e.org) `[d](no.md)`")
    assert links == ["docs/A.md#x", "docs/images/b.png", "https://e.org", "no.md"]


#: a path of the repository written in backticks: `tests/shade/test_match.py`, `app/studio/launch.py`
_CODE_PATH = re.compile(r"`((?:app|bench|capture|catalogue|core|km|painting|project|render|resources|scripts|shade|"
                        r"tests)/[\w./-]+\.(?:py|glsl|json|toml|csv))(?::\d+)?`")


@pytest.mark.parametrize("doc", doc_files(), ids=lambda p: p.name)
def test_every_file_the_docs_name_exists(doc: Path) -> None:
    """A test, module or shader a page cites (in backticks) exists: a claim keeps its evidence when files move."""
    missing = [f"{doc.name}:{number}: {m.group(1)}" for number, line in prose_lines(doc)
               for m in _CODE_PATH.finditer(line) if not (ROOT / m.group(1)).exists()]
    assert not missing, "\n".join(missing)
