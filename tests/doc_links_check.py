#!/usr/bin/env python3
"""Every relative link of the guides resolves: README.md, CONTRIBUTING.md and docs/*.md.

    tests/doc_links_check.py [ROOT]

A link [text](target) or image ![alt](target) whose target is not a URL must name an existing
file or folder relative to the page; a #anchor into a Markdown page must name one of its headings
(GitHub's slugs). Links inside code spans and fenced blocks are not links. Exits 1 naming every
broken link as FILE:LINE: target: problem.
"""
import pathlib
import re
import sys

LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def slug(heading):
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = heading.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def prose_lines(text):
    """(line number, line, line with code spans blanked) outside fenced code blocks."""
    fenced = False
    for number, line in enumerate(text.split("\n"), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if not fenced:
            yield number, line, re.sub(r"`[^`]*`", "``", line)


def anchors(page):
    """The anchors of a page's headings."""
    return {slug(re.sub(r"^#{1,6} ", "", line)) for _, line, _ in prose_lines(page.read_text(encoding="utf-8"))
            if re.match(r"#{1,6} ", line)}


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent).resolve()
    pages = [root / "README.md"] + sorted(root.glob("CONTRIBUTING.md")) + sorted((root / "docs").glob("*.md"))
    problems, links = [], 0
    for page in pages:
        if not page.exists():
            problems.append(f"{page.relative_to(root)}: missing")
            continue
        for number, _, line in prose_lines(page.read_text(encoding="utf-8")):
            for target in LINK.findall(line):
                if re.match(r"[a-z]+:", target):  # https:, mailto:
                    continue
                links += 1
                path, _, anchor = target.partition("#")
                where = f"{page.relative_to(root)}:{number}: {target}"
                resolved = (page.parent / path).resolve() if path else page
                if not resolved.exists():
                    problems.append(f"{where}: no such file")
                elif anchor and resolved.suffix == ".md" and anchor not in anchors(resolved):
                    problems.append(f"{where}: no heading #{anchor} in {resolved.relative_to(root)}")
    for problem in problems:
        print(problem)
    if problems:
        return 1
    print(f"doc_links_check: {links} relative links in {len(pages)} pages resolve")
    return 0


if __name__ == "__main__":
    sys.exit(main())
