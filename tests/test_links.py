"""Every link of the repository's Markdown pages to a file of the repository, and every mention of a path
under docs/ or studies/ in its pages, code and configs, names a path that exists (results moved out of
docs/ into studies/ leave no dangling reference behind)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

from tests.support import ROOT

#: A Markdown link or image: its target, up to an optional title or anchor.
LINK = re.compile(r"!?\[[^\]]*\]\(<?([^)\s>#]+)")
#: A repository path under docs/ or studies/ written in prose or code, not part of a longer path.
MENTION = re.compile(r"(?<![\w./-])((?:docs|studies)/[\w./{},*-]*[\w/}*])")
#: The files whose mentions are checked: tracked text files outside test fixtures and logs.
TEXT = {".md", ".py", ".yaml", ".yml", ".sh", ".toml", ".txt"}


def _tracked() -> list[Path]:
    names = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return [ROOT / name for name in names.splitlines() if (ROOT / name).is_file()]


def _exists(path: str, base: Path) -> bool:
    """Whether `path` (relative to `base`; `{a,b}` alternatives expanded, `*` matched) names existing files or
    folders."""
    choice = re.search(r"\{([^{}]*)\}", path)
    if choice:
        return all(_exists(path[: choice.start()] + option + path[choice.end():], base)
                   for option in choice.group(1).split(","))
    if "*" in path:
        return any(base.glob(path.rstrip("/")))
    return (base / path).exists()


def test_markdown_links_name_existing_files():
    pages = [ROOT / "README.md", ROOT / "ARCHITECTURE.md", *sorted((ROOT / "docs").glob("*.md")),
             *sorted((ROOT / "studies").rglob("*.md")), *sorted((ROOT / "benchmarks").rglob("*.md"))]
    broken = []
    for page in pages:
        for number, line in enumerate(page.read_text().splitlines(), 1):
            for target in LINK.findall(line):
                if re.match(r"[a-z]+:", target):  # http:, https:, mailto:
                    continue
                if not _exists(target, page.parent):
                    broken.append(f"{page.relative_to(ROOT)}:{number}: {target}")
    assert len(pages) > 20 and not broken, "\n".join(broken)


def test_mentioned_docs_and_studies_paths_exist():
    broken = []
    for path in _tracked():
        if path.suffix not in TEXT or path.name == "Makefile":
            continue
        text = path.read_text(errors="replace")
        if path.suffix == ".md":  # commands in code blocks name their own output folders, not ours
            text = re.sub(r"^```.*?^```", lambda block: "\n" * block.group(0).count("\n"), text, flags=re.M | re.S)
        for number, line in enumerate(text.splitlines(), 1):
            for mention in MENTION.findall(line):
                if not _exists(mention.rstrip("."), ROOT):
                    broken.append(f"{path.relative_to(ROOT)}:{number}: {mention}")
    assert not broken, "\n".join(broken)
