"""The repository's text keeps its own house rules: every page it names exists, every link in the docs resolves,
and nothing points at history (a working session, an issue number) or at a path outside the repository.

History lives in git and the evidence for a choice in ``docs/decisions/``; a reader of a docstring, a comment or a
page must be able to follow every reference from a fresh clone.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Files whose text is read: code, docs, configuration and scripts (data files such as CSV and JSONL are not).
TEXT_SUFFIXES = {".py", ".md", ".yaml", ".yml", ".toml", ".sh", ".cfg", ".ini", ".txt"}
#: A page named from anywhere in the repository.
DOCS_PATH = re.compile(r"\bdocs/[\w./-]*?\.md\b")
#: A Markdown link target (inline form), without its anchor.
MD_LINK = re.compile(r"\]\(([^)\s#]*)(?:#[^)\s]*)?\)")
#: Words that point at history or outside the repository.
FORBIDDEN = {
    "a working session": re.compile(r"\b[Ss]essions? \(?\d+"),
    "an issue number": re.compile(r"\b[Ii]ssues? #?\d+"),
    "a path outside the repository": re.compile(r"/work/|\.\./shared|\bnotes/s\d+"),
}


def repository_files() -> list[Path]:
    """Tracked text files (or, outside a git checkout, every text file below the root)."""
    try:
        out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                             capture_output=True, text=True, check=True).stdout.split()
        paths = [ROOT / p for p in out]
    except (OSError, subprocess.CalledProcessError):
        paths = [p for p in ROOT.rglob("*") if ".git" not in p.parts]
    return sorted(p for p in paths if p.suffix in TEXT_SUFFIXES and p.is_file())


FILES = repository_files()


def _ids(paths: list[Path]) -> list[str]:
    return [str(p.relative_to(ROOT)) for p in paths]


@pytest.mark.parametrize("path", FILES, ids=_ids(FILES))
def test_no_history_and_no_outside_path(path):
    if path == Path(__file__).resolve():
        return
    problems = []
    for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        for what, pattern in FORBIDDEN.items():
            if pattern.search(line):
                problems.append(f"line {number} names {what}: {line.strip()[:120]}")
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("path", FILES, ids=_ids(FILES))
def test_every_named_docs_page_exists(path):
    text = path.read_text(encoding="utf-8", errors="replace")
    missing = sorted({m for m in DOCS_PATH.findall(text) if not (ROOT / m).is_file()})
    assert not missing, f"names pages that do not exist: {', '.join(missing)}"


MARKDOWN = [p for p in FILES if p.suffix == ".md"]


@pytest.mark.parametrize("path", MARKDOWN, ids=_ids(MARKDOWN))
def test_markdown_links_resolve(path):
    broken = []
    for target in MD_LINK.findall(path.read_text(encoding="utf-8")):
        if not target or re.match(r"^[a-z]+:", target):     # an anchor on this page; http:, mailto: (offline)
            continue
        if not (path.parent / target).exists():
            broken.append(target)
    assert not broken, f"links that do not resolve: {', '.join(broken)}"
