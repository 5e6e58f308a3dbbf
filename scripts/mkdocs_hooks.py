"""mkdocs hooks (mkdocs.yml `hooks:`): the committed notebooks in notebooks/ become pages under
notebooks/ of the site without a copy in docs/; mkdocs-jupyter renders them as committed (no run).
After the build, every page's links are checked as a browser opening the site from disk would follow
them (a warning each, so `--strict` fails): mkdocs validates the links of Markdown pages only, not of
the notebooks' pages nor of what the theme adds."""

from __future__ import annotations

import html
import os
import re
from pathlib import Path
from urllib.parse import unquote, urlsplit

from mkdocs.plugins import event_priority, get_plugin_logger
from mkdocs.structure.files import File, Files

REPO = Path(__file__).resolve().parent.parent
NOTEBOOKS = REPO / "notebooks"
log = get_plugin_logger("site_links")

_TAG = re.compile(r"<(a|link|script|img|source|iframe)\b[^>]*>", re.I)
_URL = re.compile(r'\s(href|src)="([^"]*)"', re.I)
_ID = re.compile(r'\s(?:id|name)="([^"]*)"', re.I)
_BODY = re.compile(r"(<(script|style|pre)\b[^>]*>).*?</\2>", re.I | re.S)  # code and inline scripts: text, not links


@event_priority(100)  # before mkdocs-jupyter's on_files, which turns .ipynb files into pages
def on_files(files: Files, config) -> Files:
    for nb in sorted(NOTEBOOKS.glob("*.ipynb")):
        # src_dir is the checkout, so the page's source path is notebooks/NAME under it (mkdocs-jupyter
        # wraps the file and derives the path it reads from src_dir, which a generated file lacks)
        files.append(File(f"notebooks/{nb.name}", src_dir=str(REPO), dest_dir=config["site_dir"],
                          use_directory_urls=config["use_directory_urls"]))
    return files


def _anchors(page: Path, cache: dict[Path, set[str]]) -> set[str]:
    if page not in cache:
        cache[page] = {html.unescape(m) for m in _ID.findall(page.read_text(encoding="utf-8", errors="replace"))}
    return cache[page]


def site_link_problems(site_dir: str | Path) -> list[str]:
    """What a reader of the site opened from disk (file://) would find broken: a link to a folder (a
    directory listing), to a file that is not there, to an anchor the page lacks, and a script,
    stylesheet or image that needs the network. An empty list when there is none."""
    site = Path(site_dir).resolve()
    problems: list[str] = []
    cache: dict[Path, set[str]] = {}
    kinds: dict[Path, str | None] = {}
    for page in sorted(site.rglob("*.html")):
        rel = page.relative_to(site).as_posix()
        if rel == "404.html":  # served by a web server at any path, its links are absolute on purpose
            continue
        text = page.read_text(encoding="utf-8", errors="replace")
        cache.setdefault(page, {html.unescape(m) for m in _ID.findall(text)})
        for tag in _TAG.finditer(_BODY.sub(r"\1", text)):
            name = tag.group(1).lower()
            for attr, raw in _URL.findall(tag.group(0)):
                url = html.unescape(raw).strip()
                parts = urlsplit(url)
                if parts.scheme in ("http", "https") or url.startswith("//"):
                    if name != "a" and not (name == "link" and re.search(r'rel="(canonical|preconnect)"', tag.group(0))):
                        problems.append(f"{rel}: <{name} {attr}> needs the network: {url}")
                    continue
                if parts.scheme or not url:  # mailto:, data:, javascript:
                    continue
                target = page if not parts.path else Path(os.path.normpath(page.parent / unquote(parts.path)))
                if target not in kinds:
                    kinds[target] = "dir" if target.is_dir() else "file" if target.exists() else None
                if kinds[target] is None:
                    problems.append(f"{rel}: {url} links to a missing file")
                elif kinds[target] == "dir":
                    problems.append(f"{rel}: {url} links to a folder (from disk: a directory listing)")
                elif parts.fragment and target.suffix == ".html" and unquote(parts.fragment) not in _anchors(target, cache):
                    problems.append(f"{rel}: {url} links to an anchor its page lacks")
    return list(dict.fromkeys(problems))  # a link the page repeats (its two tables of contents): once


@event_priority(-200)  # after every plugin's post_build (the offline plugin's search index included)
def on_post_build(config) -> None:
    for problem in site_link_problems(config["site_dir"]):
        log.warning(problem)
