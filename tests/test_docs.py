"""Every document the code cites is in the repository, and its cited sections exist."""

import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCES = ("cpg_suite", "baselines", "analysis", "benchmarks", "tests", "docs")
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
