#!/usr/bin/env python3
"""Checks that the repository's citations of its own files resolve.

Scans host/, kernels/, tests/, tools/, .ci/, CMakeLists.txt, docs/ and
README.md (in tests/data/ and tools/bench-results/, which hold data, only
the Markdown files) and prints one line per broken citation,

    FILE:LINE: cites X, which ...

and exits 1 when there is one (0 when every citation resolves, 2 on a usage
error). What counts as a citation:

(a) a path-like token ending in .md, .h, .cpp, .cl, .py, .sh, .json, .xml,
    .exr or .png. It resolves against the repository root, then the citing
    file's folder and the folders above it (relative includes such as
    lib/estimate.h inside kernels/, ../spm_types.h in kernels/lib/, a
    Markdown link), then the include roots host/, kernels/ and tests/
    (spm/map_grids.h). A bare file name (spm_types.h) resolves when a file of
    that name exists anywhere in the repository (a name several files share,
    such as README.md, is not checked further). Skipped: tokens with a glob
    (*) or a placeholder (FILE, PREFIX, NAME, SCENE.xml, OUT.exr, x.xml:
    an upper-case word, or a one-letter name), generated outputs (out/, build/, build-asan/, /tmp/ and
    other absolute paths, $VARIABLES), URLs, and system headers in
    #include <...>;
(b) a bare METHOD.md, SCENES.md or STYLE.md means docs/<that>;
(c) "METHOD.md N" (also "N-M" and "N, M") must name a section "## N." of
    docs/METHOD.md;
(d) X.md "Heading" (and README "Heading", meaning the top-level README.md)
    must name a heading of that file: a line of 1 to 4 '#' whose text is
    Heading, case-sensitive, or begins with Heading followed by " (", ", "
    or ": " (citations name "Gather rays aimed at the glow" for the heading
    "Gather rays aimed at the glow (issue 14, fifth session)"). Further
    quoted headings chained after it (X.md "A", "B") are checked too, except
    those starting with "...". A citation may wrap onto the next line of a
    comment;
(e) ../shared/ anywhere is an error: a clone of the repository does not have
    it; cite the copies in docs/.

The repository's files are those git lists (tracked, and untracked but not
ignored); outside a git work tree, those on disk. --list prints every
citation checked, with what it resolved to.

Usage: tools/check_citations.py [--list] [--root DIR]
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

SCAN_DIRS = ("host", "kernels", "tests", "tools", ".ci", "docs")
SCAN_FILES = ("CMakeLists.txt", "README.md")
DATA_DIRS = ("tests/data/", "tools/bench-results/")  # only their Markdown is scanned
TEXT_SUFFIXES = {".h", ".hpp", ".c", ".cpp", ".cl", ".py", ".sh", ".md", ".txt", ".json", ".cmake", ".supp",
                 ".xml", ".in", ".dict", ""}
CITED_EXT = r"(?:md|h|cpp|cl|py|sh|json|xml|exr|png)"
INCLUDE_ROOTS = ("host", "kernels", "tests")
BARE_DOCS = {"METHOD.md", "SCENES.md", "STYLE.md"}
GENERATED = ("out/", "build/", "build-asan/", "/tmp/")
PLACEHOLDER = re.compile(r"^[A-Z][A-Z0-9]*(?:_[A-Za-z0-9]+)*$")  # FILE, PREFIX_volume, OUT, SCENE, A
# Paths cited on purpose although no file is there, with the reason.
NOT_FILES = {
    "tests/data/scene/fuzz.xml": "the name the fuzz target gives its input, so that includes resolve beside it",
}
DOC_NAMES = re.compile(r"^(?:README|METHOD|SCENES|STYLE|TUNING|ARCHITECTURE|TESTING|CHANGELOG|LICENSE|CONTRIBUTING)$")

TOKEN = re.compile(r"[A-Za-z0-9_./+*${}~@%-]+")
CITED = re.compile(r"\." + CITED_EXT + r"$")
INCLUDE_SYSTEM = re.compile(r"#\s*include\s*<[^>]*>")
URL = re.compile(r"[a-z]+://\S+")
# (c): METHOD.md followed by section numbers.
METHOD_SECTION = re.compile(r"(?<![\w/.-])(?:docs/)?METHOD\.md[`\]]?\s+(\d+)((?:\s*(?:,|-|and)\s*\d+)*)\b(?![.\d]*\w)")
# (d): a file, then its quoted heading (quotes may be JSON-escaped), possibly wrapped over a comment line.
HEADING_CITE = re.compile(r"(?<![\w/.-])(?:((?:[\w.+-]+/)*[\w.+-]+\.md)`?|(README),?)\s+"
                          r"\\?\"([^\"\\]+)\\?\"((?:\s*,\s*\\?\"[^\"\\]+\\?\")*)")
CHAINED = re.compile(r"\\?\"([^\"\\]+)\\?\"")
COMMENT_LEAD = re.compile(r"^\s*(?://+|/?\*+|#+|--|;+)?\s?")


def repo_files(root: Path) -> list[str]:
    try:
        out = subprocess.run(["git", "-C", str(root), "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                             capture_output=True, check=True).stdout
        files = [f for f in out.decode("utf-8", "replace").split("\0") if f]
        return sorted({f for f in files if (root / f).is_file()})
    except (OSError, subprocess.CalledProcessError):
        found = []
        for dirpath, dirnames, filenames in os.walk(root):
            dirnames[:] = [d for d in dirnames if d not in (".git", "build", "build-asan", "out")]
            for n in filenames:
                found.append(os.path.relpath(os.path.join(dirpath, n), root))
        return sorted(found)


def scanned(files: list[str], self_path: str) -> list[str]:
    picked = []
    for f in files:
        if f == self_path:
            continue  # its docstring's examples are not citations
        if not (f in SCAN_FILES or f.split("/", 1)[0] in SCAN_DIRS):
            continue
        if f.startswith(DATA_DIRS) and not f.endswith(".md"):
            continue
        if Path(f).suffix not in TEXT_SUFFIXES:
            continue
        picked.append(f)
    return picked


def headings(text: str) -> list[str]:
    found, fence = [], False
    for line in text.split("\n"):
        if line.lstrip().startswith("```"):
            fence = not fence
            continue
        m = None if fence else re.match(r"#{1,4} +(.*?)\s*#*\s*$", line)
        if m:
            found.append(m.group(1))
    return found


def names_heading(cited: str, heads: list[str]) -> bool:
    return any(h == cited or (h.startswith(cited) and h[len(cited):len(cited) + 2] in (" (", ", ", ": "))
               for h in heads)


class Repo:
    def __init__(self, root: Path):
        self.root = root
        self.files = repo_files(root)
        self.file_set = set(self.files)
        self.dirs = {str(Path(f).parent) for f in self.files}
        for f in list(self.dirs):
            p = Path(f)
            while str(p) not in (".", ""):
                self.dirs.add(str(p))
                p = p.parent
        self.dir_names = {Path(d).name for d in self.dirs}
        self.by_name: dict[str, list[str]] = {}
        for f in self.files:
            self.by_name.setdefault(Path(f).name, []).append(f)
        self._text: dict[str, str] = {}
        self._heads: dict[str, list[str]] = {}

    def text(self, f: str) -> str:
        if f not in self._text:
            try:
                self._text[f] = (self.root / f).read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError):
                self._text[f] = ""
        return self._text[f]

    def heads(self, f: str) -> list[str]:
        if f not in self._heads:
            self._heads[f] = headings(self.text(f))
        return self._heads[f]

    def resolve(self, token: str, citing: str) -> str | None:
        """The repository file a path token names, or None."""
        if "/" not in token:
            if token in BARE_DOCS:
                return "docs/" + token if "docs/" + token in self.file_set else None
            near = os.path.normpath(Path(citing).parent / token)
            if near in self.file_set:
                return near
            hits = self.by_name.get(token, [])
            return hits[0] if hits else None
        candidates = [token]
        d = Path(citing).parent
        while True:
            candidates.append(os.path.normpath(d / token))
            if str(d) in (".", ""):
                break
            d = d.parent
        candidates += [os.path.normpath(Path(r) / token) for r in INCLUDE_ROOTS]
        for c in candidates:
            if c in self.file_set:
                return c
        # a path given from a folder the text named before (chains_refs/ab/ab.md): one file ends with it
        tails = [f for f in self.by_name.get(Path(token).name, []) if f.endswith("/" + token.lstrip("./"))]
        return tails[0] if len(tails) == 1 else None

    def is_repository_path(self, token: str) -> bool:
        """Whether an unresolved token with a folder looks like a path in this repository: its
        first folder is one of the repository's folders (docs/, or issue14/ under tools/), as
        opposed to another project's (Random123/philox.h) or an archive's layout."""
        first = token.lstrip("./").split("/", 1)[0]
        return first in self.dir_names


def skip_token(tok: str) -> bool:
    if "*" in tok or "$" in tok or "{" in tok or "~" in tok or "%" in tok or "@" in tok:
        return True
    if tok.startswith("/") or tok.startswith(GENERATED):
        return True
    parts = tok.split("/")
    for p in parts:
        stem = p.split(".", 1)[0]
        if stem and PLACEHOLDER.match(stem) and not DOC_NAMES.match(stem):
            return True
    stem = parts[-1].split(".", 1)[0]
    return len(stem) == 1 or tok in NOT_FILES  # x.xml, a.exr: an example's name


def check(repo: Repo, listing: bool) -> list[str]:
    broken: list[str] = []
    seen: set[str] = set()
    self_path = os.path.relpath(Path(__file__).resolve(), repo.root.resolve())
    method = "docs/METHOD.md"
    method_sections = None

    def report(where: str, what: str, resolved: str | None, problem: str | None):
        if listing:
            print(f"{where}: {what} -> {resolved if resolved else '?'}{'' if problem is None else ' BROKEN'}")
        if problem is not None:
            msg = f"{where}: cites {what}, which {problem}"
            if msg not in seen:
                seen.add(msg)
                broken.append(msg)

    for f in scanned(repo.files, self_path):
        lines = repo.text(f).split("\n")
        in_md = f.endswith(".md")
        for i, line in enumerate(lines):
            where = f"{f}:{i + 1}"
            # (e) the work tree's neighbour, which a clone does not have
            for m in re.finditer(r"\.\./shared/[\w./-]*", line):
                report(where, m.group(0).rstrip("."), None,
                       "is outside the repository (a clone does not have ../shared/; cite docs/)")
            # (a), (b): path-like tokens
            clean = URL.sub(" ", INCLUDE_SYSTEM.sub(" ", line))
            for m in TOKEN.finditer(clean):
                tok = m.group(0).rstrip(".-")
                tok = tok.lstrip("-")
                while tok.startswith("./"):
                    tok = tok[2:]
                if not CITED.search(tok) or tok.startswith("../shared/"):
                    continue
                if "/" not in tok and not re.match(r"^[\w+-][\w.+-]*$", tok):
                    continue
                if skip_token(tok):
                    continue
                if tok.startswith("shared/"):
                    report(where, tok, None, "is outside the repository (the work tree's neighbour shared/; cite docs/)")
                    continue
                # A Markdown link target is relative to the file; prose paths are root-relative.
                if in_md and clean[max(0, m.start() - 2):m.start()] == "](":
                    target = os.path.normpath(Path(f).parent / tok)
                    if target.startswith(".."):
                        continue  # outside the repository: (e) has reported ../shared/
                    resolved = target if target in repo.file_set else None
                    tok = target
                else:
                    resolved = repo.resolve(tok, f)
                if resolved is None and tok not in BARE_DOCS:
                    if "/" not in tok:
                        # A bare name no file has: a member (sc.md), a file a test writes (tiny.xml),
                        # another project's file (texture_impl.h). Not a citation to check.
                        if listing:
                            print(f"{where}: {tok} -> not in the repository, taken as not a citation")
                        continue
                    if not repo.is_repository_path(tok):
                        if listing:
                            print(f"{where}: {tok} -> outside the repository's folders, taken as not a citation")
                        continue
                report(where, tok, resolved, None if resolved else "does not exist in the repository")
            # (c) METHOD.md N
            for m in METHOD_SECTION.finditer(line):
                if method_sections is None:
                    method_sections = {re.match(r"(\d+)\.", h).group(1) for h in repo.heads(method)
                                       if re.match(r"\d+\.", h)} if method in repo.file_set else set()
                nums = [m.group(1)] + re.findall(r"\d+", m.group(2))
                for n in nums:
                    what = f"METHOD.md {n}"
                    if method not in repo.file_set:
                        report(where, what, None, f"needs {method}, which does not exist in the repository")
                    elif n not in method_sections:
                        report(where, what, method, f"is not a section of {method} (no heading '## {n}.')")
                    else:
                        report(where, what, method, None)
            # (d) X.md "Heading" / README "Heading", possibly wrapped onto the next line
            joined = line
            if i + 1 < len(lines):
                joined = line + " " + COMMENT_LEAD.sub("", lines[i + 1], count=1)
            for m in HEADING_CITE.finditer(joined):
                if m.start() >= len(line):
                    continue
                name = m.group(1) or m.group(2)
                if name.startswith(("../shared/", "shared/")):
                    continue
                target = "README.md" if name == "README" else repo.resolve(name, f)
                if name != "README" and (in_md and joined[max(0, m.start() - 2):m.start()] == "]("):
                    continue  # a link target followed by a quoted title is not a heading citation
                cited = [m.group(3)] + [c for c in CHAINED.findall(m.group(4)) if not c.startswith("...")]
                for h in cited:
                    h = re.sub(r"\s+", " ", h).strip()
                    what = f'{name} "{h}"'
                    if target is None or target not in repo.file_set:
                        if name == "README" or not skip_token(name):
                            report(where, what, None, "names a file that does not exist in the repository")
                    elif not names_heading(h, repo.heads(target)):
                        report(where, what, target, f"has no such heading in {target}")
                    else:
                        report(where, what, target, None)
    return broken


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                epilog="See the module docstring for what counts as a citation.")
    p.add_argument("--list", action="store_true", help="print every citation checked and what it resolved to")
    p.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent,
                   help="repository root (default: this script's repository)")
    args = p.parse_args()
    repo = Repo(args.root)
    broken = check(repo, args.list)
    for b in broken:
        print(b)
    if broken:
        print(f"check_citations: {len(broken)} broken citation(s)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
