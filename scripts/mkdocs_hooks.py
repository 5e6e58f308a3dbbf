"""mkdocs hooks (mkdocs.yml `hooks:`): the committed notebooks in notebooks/ become pages under
notebooks/ of the site without a copy in docs/; mkdocs-jupyter renders them as committed (no run)."""

from __future__ import annotations

from pathlib import Path

from mkdocs.plugins import event_priority
from mkdocs.structure.files import File, Files

REPO = Path(__file__).resolve().parent.parent
NOTEBOOKS = REPO / "notebooks"


@event_priority(100)  # before mkdocs-jupyter's on_files, which turns .ipynb files into pages
def on_files(files: Files, config) -> Files:
    for nb in sorted(NOTEBOOKS.glob("*.ipynb")):
        # src_dir is the checkout, so the page's source path is notebooks/NAME under it (mkdocs-jupyter
        # wraps the file and derives the path it reads from src_dir, which a generated file lacks)
        files.append(File(f"notebooks/{nb.name}", src_dir=str(REPO), dest_dir=config["site_dir"],
                          use_directory_urls=config["use_directory_urls"]))
    return files
