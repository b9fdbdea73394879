#!/usr/bin/env python3
"""Checks that the documents stay readable: words per paragraph and per sentence, README length,
BENCHMARKS length. Prints file:line: what, for each breach; exits 1 if there is any.

Usage: check_prose.py [--root DIR] [--files FILE...]
  Without --files: README.md (paragraph <= 80 words, sentence <= 40, whole file <= 1,500 words),
  docs/*.md and configs/interhand/README.md (paragraph <= 100, sentence <= 40), and
  docs/BENCHMARKS.md at most 400 lines. --files checks the given files with the docs' limits.

A paragraph is a run of non-blank lines. Exempt: fenced code blocks, table rows (lines starting
with '|'), headings ('#') and images ('!['). Each list item ('- ', '* ', '1. ') is a paragraph of
its own. Sentences end at '.', '!' or '?' followed by a space and a capital, '(', '*' or '[';
inline code counts as one word and 'e.g.', 'i.e.', 'etc.', 'vs.', 'cf.' end no sentence. These
rules match the reviewers' measure (shared/tools/prose_stats.py).
"""
import argparse
import os
import pathlib
import re
import sys

LIST_ITEM = re.compile(r"^([-*]|\d+\.)\s")
ABBREVIATION = re.compile(r"\b(e\.g|i\.e|etc|vs|cf|Fig|Eq|Tab|approx)\.")
SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z(*\[])")


def paragraphs(text):
    """Yields (first line number, paragraph text) for every prose paragraph of a Markdown text."""
    current, start, fence = [], 0, False
    for number, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if s.startswith("```"):
            fence = not fence
        elif not (fence or not s or s.startswith(("|", "#", "!["))):
            if LIST_ITEM.match(s):
                if current:
                    yield start, " ".join(current)
                current, start = [LIST_ITEM.sub("", s, count=1).lstrip()], number
            else:
                if not current:
                    start = number
                current.append(s)
            continue
        if current:
            yield start, " ".join(current)
        current = []
    if current:
        yield start, " ".join(current)


def words(s):
    return len(s.split())


def sentences(paragraph):
    paragraph = re.sub(r"`[^`]*`", "CODE", paragraph)
    paragraph = ABBREVIATION.sub(r"\1", paragraph)
    return [s for s in SENTENCE_END.split(paragraph) if s.strip()]


def check(path, max_paragraph, max_sentence, max_words=None, max_lines=None):
    """Returns the breaches of one file as 'path:line: message' strings."""
    text = path.read_text(encoding="utf-8")
    name = os.path.relpath(path)
    found = []
    for line, paragraph in paragraphs(text):
        n = words(paragraph)
        if n > max_paragraph:
            found.append(f"{name}:{line}: paragraph of {n} words (at most {max_paragraph})")
        for sentence in sentences(paragraph):
            n = words(sentence)
            if n > max_sentence:
                found.append(f"{name}:{line}: sentence of {n} words (at most {max_sentence}): "
                             f"{sentence[:60]}...")
    if max_words is not None:
        n = words(re.sub(r"```.*?```", "", text, flags=re.S))
        if n > max_words:
            found.append(f"{name}:1: {n} words in all (at most {max_words})")
    if max_lines is not None:
        n = text.count("\n")
        if n > max_lines:
            found.append(f"{name}:1: {n} lines (at most {max_lines})")
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--root", default=pathlib.Path(__file__).resolve().parent.parent,
                        type=pathlib.Path, help="repository root (default: this script's ../)")
    parser.add_argument("--files", nargs="+", type=pathlib.Path,
                        help="check these files with the docs' limits instead of the repository's")
    args = parser.parse_args()

    found = []
    if args.files:
        for path in args.files:
            found += check(path, 100, 40)
    else:
        root = args.root
        found += check(root / "README.md", 80, 40, max_words=1500)
        docs = sorted((root / "docs").glob("*.md")) + [root / "configs/interhand/README.md"]
        for path in docs:
            found += check(path, 100, 40, max_lines=400 if path.name == "BENCHMARKS.md" else None)
    for breach in found:
        print(breach)
    sys.stdout.flush()  # the summary (stderr) comes after the breaches
    if found:
        print(f"{len(found)} breach(es) of the document limits", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
