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


def on_files(files, config):
    for page, source in EXTERNAL_PAGES.items():
        text = (ROOT / source).read_text(encoding="utf-8")
        if source.startswith("benchmarks/"):
            for old, new in _LINKS.items():
                text = text.replace(old, new)
        files.append(File.generated(config, page, content=text))
    return files
