"""Every document the code cites is in the repository, and its cited sections exist."""

import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCES = ("cpg_suite", "baselines", "analysis", "benchmarks", "tests", "docs")
CITATION = re.compile(r"docs/([A-Za-z0-9_./-]+\.md)(?:#([a-z0-9-]+))?")
OUTSIDE = re.compile(r"DESIGN Sec|THESIS\.md|facts Sec|darwin_op_facts|shared/spec")


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
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("#"):
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
        assert "](docs/" in f.read()
