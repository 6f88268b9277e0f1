"""MkDocs hook: pages whose source lives outside ``docs/`` (the benchmark tables and the fitting
workflows, each kept beside its scripts) are added to the site as generated pages, so that the
site and the repository show one text."""

from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parent.parent

#: site page -> source file (relative to the repository root)
EXTERNAL_PAGES = {
    "benchmarks.md": "benchmarks/README.md",
    "benchmarks-log.md": "benchmarks/LOG.md",
    "fitting.md": "fitting/README.md",
}


#: links between the external sources, as the site names their pages
_LINKS = {"](LOG.md": "](benchmarks-log.md", "](README.md)": "](benchmarks.md)"}
#: fitting/README.md's links into docs/ and benchmarks/, as the site names those pages
_FITTING_LINKS = {"](../docs/": "](", "](../benchmarks/LOG.md": "](benchmarks-log.md",
                  "](../benchmarks/README.md": "](benchmarks.md"}


def on_files(files, config):
    for page, source in EXTERNAL_PAGES.items():
        text = (ROOT / source).read_text(encoding="utf-8")
        links = _LINKS if source.startswith("benchmarks/") else _FITTING_LINKS if source.startswith("fitting/") else {}
        for old, new in links.items():
            text = text.replace(old, new)
        files.append(File.generated(config, page, content=text))
    return files
