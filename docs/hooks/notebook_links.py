"""An MkDocs hook: the links of a notebook page point to the site's pages, and are checked.

MkDocs rewrites and checks the links of Markdown pages (``../fitting.md`` becomes the page's
URL; a missing page or anchor fails ``--strict``). A notebook page is converted to HTML by
mkdocs-jupyter instead, so its links would stay as written: right in Jupyter and on a repository
browser, wrong in the site. This hook gives a notebook's relative links to ``.md`` and
``.ipynb`` files the same treatment: each becomes the URL of the page it names, and a link to a
file that is not a page of the site, or to an anchor that the page does not have, is a warning
(an error with ``--strict``).
"""

from __future__ import annotations

import html
import logging
import posixpath
import re
from typing import Any

from mkdocs.structure.files import File, Files
from mkdocs.structure.pages import Page

log = logging.getLogger("mkdocs.hooks.notebook_links")
HREF = re.compile(r'href="([^"#:]*\.(?:md|ipynb))(#[^"]*)?"')
# (notebook, target page's file, anchor): checked once every page has been rendered
ANCHORS: list[tuple[str, File, str]] = []


def on_page_content(html_text: str, page: Page, config: Any, files: Files) -> str:
    """Rewrite the relative page links of a notebook page to the pages' URLs."""
    if not page.file.src_uri.endswith(".ipynb"):
        return html_text

    def link(match: re.Match[str]) -> str:
        path, anchor = html.unescape(match.group(1)), match.group(2) or ""
        uri = posixpath.normpath(posixpath.join(posixpath.dirname(page.file.src_uri), path))
        target = files.get_file_from_path(uri)
        if target is None or not target.is_documentation_page() or target.inclusion.is_excluded():
            log.warning(f"{page.file.src_uri}: link to {path!r}, which is not a page of the site")
            return match.group(0)
        if anchor:
            ANCHORS.append((page.file.src_uri, target, anchor[1:]))
        return f'href="{target.url_relative_to(page.file)}{anchor}"'

    return HREF.sub(link, html_text)


def on_post_build(config: Any) -> None:
    """Check the anchors named by notebook links, now that every page knows its anchors."""
    for notebook, target, anchor in ANCHORS:
        ids = target.page.present_anchor_ids if target.page is not None else None
        if ids is not None and anchor not in ids:  # (None: a page mkdocs did not render)
            log.warning(f"{notebook}: link to '{target.src_uri}#{anchor}': no such anchor")
    ANCHORS.clear()
