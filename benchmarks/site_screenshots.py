"""Benchmark (by hand): the built site in a headless browser, as a reader opens it from a file.

Opens pages of ``site/`` (``.venv/bin/sphinx-build -W --keep-going -b html docs site``) as
``file://`` URLs at 1280 x 900, takes a full-page screenshot of each and measures what a reader
would see cut off or missing: the page's width against the window's, the elements of the article
whose content is wider than their box and that no scrolling box holds (a code block or a table cut
off at the right edge), and the images shown (``<img>`` with a ``naturalWidth``) against those on
the page. Then it types a word into the search page and counts the results (Sphinx's search reads
``searchindex.js``, which must work from a file too). Prints one row per page.

Needs playwright (``.venv/bin/pip install playwright``, not a dependency of the package) and a
Chromium; Debian's ``/usr/bin/chromium`` is used as it is (no browser download)::

    .venv/bin/python benchmarks/site_screenshots.py [--site site] [--out screens] [--word fit]
        [--chromium /usr/bin/chromium] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WIDTH, HEIGHT = 1280, 900
#: The pages checked: the home page, a guide page, the verification page and the gallery.
PAGES = {
    "home": "index.html",
    "guide: fit": "guide/fit-and-posterior.html",
    "verification": "validation/verification.html",
    "gallery": "auto_examples/index.html",
}

#: In the page: the document's width, the article's images, and its elements whose content spills
#: out of their box with no box around them (or themselves) that scrolls or that is hidden.
MEASURE = """() => {
  const article = document.querySelector('.bd-article') || document.body;
  const scrolls = (el) => {
    for (let e = el; e && e !== document.body; e = e.parentElement) {
      const s = getComputedStyle(e);
      if (['auto', 'scroll'].includes(s.overflowX) && e.clientWidth > 0) return true;
    }
    return false;
  };
  const visible = (el) => el.getClientRects().length > 0 && getComputedStyle(el).visibility !== 'hidden';
  const over = [];
  for (const el of article.querySelectorAll('*')) {
    if (!visible(el) || scrolls(el)) continue;
    const right = el.getBoundingClientRect().right;
    if (el.scrollWidth > el.clientWidth + 1 && el.clientWidth > 0 || right > window.innerWidth + 1) {
      over.push(`${el.tagName.toLowerCase()}.${[...el.classList].join('.')} ${el.scrollWidth}>${el.clientWidth}`);
    }
  }
  const images = [...article.querySelectorAll('img')];
  return {
    page_width: document.documentElement.scrollWidth,
    page_height: document.documentElement.scrollHeight,
    images: images.length,
    images_shown: images.filter((i) => i.complete && i.naturalWidth > 0).length,
    overflowing: over,
  };
}"""


def measure_pages(
    site: Path, out: Path, chromium: str, word: str, pages: dict[str, str] | None = None
) -> tuple[list[dict], dict]:
    """Screenshots and measurements of ``pages`` (default :data:`PAGES`), and a search for ``word``.

    Parameters
    ----------
    site : pathlib.Path
        The built site (the folder holding ``index.html``).
    out : pathlib.Path
        Where the full-page PNGs go.
    chromium : str
        The Chromium executable.
    word : str
        The word searched for on ``search.html``.
    pages : dict, optional
        Name -> page file relative to ``site`` (default :data:`PAGES`).

    Returns
    -------
    rows : list of dict
        Per page: its name, file, width and height (px), images on the page and shown, and the
        overflowing elements found.
    search : dict
        The word and the number of results the search page listed.
    """
    from playwright.sync_api import sync_playwright

    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--allow-file-access-from-files"])
        page = browser.new_page(viewport={"width": WIDTH, "height": HEIGHT})
        for name, rel in (pages or PAGES).items():
            page.goto((site / rel).resolve().as_uri(), wait_until="load")
            page.wait_for_timeout(500)  # the theme's scripts settle the layout
            found = page.evaluate(MEASURE)
            png = out / f"{rel.replace('/', '_').removesuffix('.html')}.png"
            page.screenshot(path=str(png), full_page=True)
            rows.append({"page": name, "file": rel, "png": str(png), **found})
        page.goto((site / "search.html").resolve().as_uri() + f"?q={word}", wait_until="load")
        finished = "(document.querySelector('#search-results') || {innerText: ''}).innerText"
        page.wait_for_function(f"{finished}.includes('Search finished')", timeout=60_000)
        results = page.evaluate("document.querySelectorAll('#search-results li').length")
        page.screenshot(path=str(out / "search.png"), full_page=False)
        browser.close()
    return rows, {"word": word, "results": results}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--site", type=Path, default=ROOT / "site", help="the built site")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "screens", help="where the PNGs go")
    parser.add_argument("--word", default="fit", help="the word searched for")
    parser.add_argument("--chromium", default="/usr/bin/chromium", help="the Chromium executable")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    parser.add_argument(
        "--pages", help="comma-separated page files relative to --site (default: the four pages of PAGES)"
    )
    args = parser.parse_args(argv)
    # keyed by the path without .html: two pages of one name in two folders are two pages
    pages = None if not args.pages else {rel.removesuffix(".html"): rel for rel in args.pages.split(",")}
    rows, search = measure_pages(args.site, args.out, args.chromium, args.word, pages)
    if args.json:
        print(json.dumps({"pages": rows, "search": search}))
    else:
        print(f"{'page':<14}{'width':>7}{'height':>8}{'images':>8}{'shown':>7}{'overflowing':>13}")
        for r in rows:
            print(
                f"{r['page']:<14}{r['page_width']:>7}{r['page_height']:>8}{r['images']:>8}"
                f"{r['images_shown']:>7}{len(r['overflowing']):>13}"
            )
            for element in r["overflowing"][:10]:
                print(f"    {element}")
        print(f"search for {search['word']!r}: {search['results']} results (from a file)")
    too_wide = [r["page"] for r in rows if r["page_width"] > WIDTH or r["overflowing"]]
    missing = [r["page"] for r in rows if r["images_shown"] < r["images"]]
    return 1 if too_wide or missing or not search["results"] else 0


if __name__ == "__main__":
    sys.exit(main())
