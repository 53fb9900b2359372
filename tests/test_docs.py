"""Every document the code cites is in the repository, and its cited sections exist."""

import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCES = ("cpg_suite", "baselines", "analysis", "benchmarks", "investigations", "tests", "docs")
# A citation: docs/<file>.md, optionally #<anchor> (GitHub-style: the heading in lower case,
# punctuation dropped, spaces as hyphens). Upper case is captured so that it fails.
CITATION = re.compile(r"docs/([A-Za-z0-9_./-]+\.md)(?:#([A-Za-z0-9_-]+))?")
# A relative markdown link between the documents: [text](file.md#anchor).
DOC_LINK = re.compile(r"\]\(([A-Za-z0-9_./-]+\.md)(?:#([A-Za-z0-9_-]+))?\)")
# Documents that do not ship with the repository: the design and digest files, the robot's
# fact sheet, section signs and line numbers of those files.
OUTSIDE = re.compile(
    r"DESIGN(?:\.md| Sec)|THESIS\.md|facts Sec|facts sheet|darwin_op_facts|shared/(?:spec|seed)"
    r"|§\s?\d|\(L\d{3,}[,)]"
)


def _files():
    yield os.path.join(ROOT, "README.md")
    for top in SOURCES:
        for dirpath, _, names in os.walk(os.path.join(ROOT, top)):
            for name in names:
                if name.endswith((".py", ".xml", ".md")):
                    yield os.path.join(dirpath, name)


def _anchors(path: str) -> set:
    """GitHub-style anchors of a markdown file's headings."""
    anchors = set()
    fenced = False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("```"):
                fenced = not fenced
            elif not fenced and re.match(r"#{1,6} ", line):
                title = line.lstrip("#").strip().lower()
                title = re.sub(r"[^\w\- ]", "", title, flags=re.UNICODE)
                anchors.add(title.replace(" ", "-"))
    return anchors


def test_every_cited_document_and_section_exists():
    cited = 0
    for path in _files():
        with open(path, encoding="utf-8") as f:
            text = f.read()
        for name, anchor in CITATION.findall(text):
            target = os.path.join(ROOT, "docs", name)
            assert os.path.isfile(target), f"{path} cites missing docs/{name}"
            if anchor:
                assert anchor in _anchors(target), f"{path} cites missing docs/{name}#{anchor}"
            cited += 1
    assert cited >= 20


def test_links_between_documents_resolve():
    docs = os.path.join(ROOT, "docs")
    for name in sorted(os.listdir(docs)):
        if not name.endswith(".md"):
            continue
        with open(os.path.join(docs, name), encoding="utf-8") as f:
            text = f.read()
        for target, anchor in DOC_LINK.findall(text):
            path = os.path.normpath(os.path.join(docs, target))
            assert os.path.isfile(path), f"docs/{name} links missing {target}"
            if anchor:
                assert anchor in _anchors(path), f"docs/{name} links missing {target}#{anchor}"


def test_every_document_is_in_the_index():
    docs = os.path.join(ROOT, "docs")
    with open(os.path.join(docs, "README.md"), encoding="utf-8") as f:
        index = f.read()
    for name in sorted(os.listdir(docs)):
        if name.endswith(".md") and name != "README.md":
            assert f"]({name})" in index, f"docs/README.md does not list {name}"


def test_no_citation_points_outside_the_repository():
    this = os.path.abspath(__file__)
    for path in _files():
        if os.path.abspath(path) == this:
            continue
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                assert not OUTSIDE.search(line), f"{path}:{number} cites outside the repo"


def test_readme_links_the_docs():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        assert "](docs/README.md)" in f.read()


# An absolute path of some machine: /dir/name (not part of a URL or a relative path), or a
# Windows drive path. Shipped documents name paths relative to the repository or `runs/`.
ABSOLUTE_PATH = re.compile(r"(?<![\w.:/~\-\]\)])/[A-Za-z_][\w.-]+/[\w.-]+|\b[A-Za-z]:\\\w")


def _shipped_documents():
    yield os.path.join(ROOT, "README.md")
    for top in ("docs", "results"):
        for dirpath, _, names in os.walk(os.path.join(ROOT, top)):
            for name in names:
                if name.endswith((".md", ".csv", ".json", ".txt")):
                    yield os.path.join(dirpath, name)


def test_absolute_path_pattern():
    found = [ABSOLUTE_PATH.search(s) for s in ("`/work/runs/full`", "--out=/tmp/pc", r"C:\runs")]
    assert all(found)
    for relative in (
        "runs/cem",
        "https://x.org/a/b",
        "0.43 N·m·s/rad",
        "max |Q|/2",
        "runs/cem/a.json",
    ):
        assert ABSOLUTE_PATH.search(relative) is None, relative


def test_shipped_documents_name_no_machine_paths():
    found = []
    for path in _shipped_documents():
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                match = ABSOLUTE_PATH.search(line)
                if match:
                    found.append(f"{os.path.relpath(path, ROOT)}:{number}: {match.group(0)}")
    assert not found, "absolute paths in shipped documents:\n" + "\n".join(found)
