"""The written test's sheets as PDF: each Markdown sheet set as an A4 page and printed by Chromium.

    python -m course.exam --seed 2026 --students s001 s002 --pdf      (beside each STUDENT-*.md, a STUDENT-*.pdf)

The sheet's Markdown becomes HTML with markdown-it (the parser MyST uses for the notes), in a page styled for
print (serif text, a line for the student's name, problems kept whole on a page where they fit); headless
Chromium, driven by Playwright, prints it. Both are the browser tests' tools: Debian's ``chromium`` and the
``playwright`` package (the dev extra); without them ``--pdf`` says so in one line.
"""

from __future__ import annotations

import html
import shutil
from pathlib import Path

STYLE = """
@page { size: A4; margin: 20mm 18mm; }
body { font-family: "DejaVu Serif", "Liberation Serif", serif; font-size: 11pt; line-height: 1.45; }
h1 { font-size: 16pt; margin: 0 0 4mm; }
h2 { font-size: 12.5pt; margin: 7mm 0 2mm; break-after: avoid; }
p { margin: 0 0 2.5mm; }
.name { margin: 0 0 6mm; border-bottom: 0.4pt solid #444; padding-bottom: 1mm; color: #444; }
section { break-inside: avoid; }
code { font-family: "DejaVu Sans Mono", monospace; font-size: 9.5pt; }
"""
"""The printed page: A4, margins for stapling, a problem not split across pages where it fits on one."""


class PdfUnavailable(RuntimeError):
    """Chromium or Playwright is missing: the message says what to install."""


def sheet_html(markdown: str, title: str) -> str:
    """The printable page of one sheet: its Markdown as HTML, each problem (a level-2 heading and what follows)
    a section, a line for the name under the title of a test sheet."""
    from markdown_it import MarkdownIt

    body = MarkdownIt("commonmark", {"html": False}).render(markdown)  # text, no markup of its own
    parts = body.split("<h2>")
    sections = parts[0] + "".join(f"<section><h2>{part}</section>" for part in parts[1:])
    if "solutions" not in title:
        sections = sections.replace("</h1>", '</h1>\n<p class="name">Name: </p>', 1)
    return (
        f"<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        f"<style>{STYLE}</style></head><body>\n{sections}</body></html>\n"
    )


def chromium() -> str:
    """The path of Debian's chromium; PdfUnavailable when it or Playwright is missing."""
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        path = None
    if path is None:
        raise PdfUnavailable(
            "--pdf prints the sheets with Chromium through Playwright: install them (Debian: apt-get install "
            "chromium; pip install playwright, or the course's dev extra) or leave --pdf out for Markdown"
        )
    return path


def write_pdfs(sheets: list[Path]) -> list[Path]:
    """Print every Markdown sheet to a PDF beside it; the PDFs written."""
    from playwright.sync_api import sync_playwright

    executable, written = chromium(), []
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=executable, args=["--no-sandbox", "--disable-gpu"])
        page = browser.new_page()
        for sheet in sheets:
            page.set_content(sheet_html(sheet.read_text(encoding="utf-8"), sheet.stem))
            target = sheet.with_suffix(".pdf")
            page.pdf(path=str(target), format="A4", prefer_css_page_size=True)
            written.append(target)
        browser.close()
    return written
