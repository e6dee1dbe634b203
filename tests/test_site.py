"""The documentation site as readers see it: every page opened in a real browser.

Headless Chromium (Debian's ``chromium`` and ``chromium-driver``, driven by Selenium; no
driver is downloaded) loads the built site from a server on this machine with every other
address unreachable, as on a machine without a network: each page must render without a
console error, its diagrams drawn as pictures (Mermaid served by the site itself), its images
loaded and its code highlighted; the search must find what readers look for. With
``MCS_SITE_SCREENSHOTS=DIR`` each page's screenshot is kept there (CI keeps them).
"""

from __future__ import annotations

import functools
import http.server
import os
import shutil
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

webdriver = pytest.importorskip("selenium.webdriver")

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
# Every host name resolves to nothing and every other connection goes to a closed port: only
# the site's own server answers.
OFFLINE = (
    "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1",
    "--proxy-server=http://127.0.0.1:9",
)
WAIT = 20.0  # s: a page's scripts to finish drawing (wall clock: a browser has no other)


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: Any) -> None:
        pass


@pytest.fixture(scope="module")
def served(site: Path) -> Iterator[str]:
    """The built site on a local HTTP server (the search's worker cannot read file: URLs)."""
    handler = functools.partial(_Quiet, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=10)


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """Headless Chromium, 1400 px wide, offline but for the site."""
    if CHROMIUM is None or DRIVER is None:
        pytest.skip("no chromium and chromedriver (scripts/setup.sh installs them on Debian)")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,2000"):
        options.add_argument(arg)
    for arg in OFFLINE:
        options.add_argument(arg)
    options.binary_location = CHROMIUM
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(DRIVER))
    driver.set_page_load_timeout(120)
    try:
        yield driver
    finally:
        driver.quit()


def _pages(site: Path) -> list[str]:
    return sorted(
        str(p.parent.relative_to(site)).replace(".", "") + "/"
        for p in site.rglob("index.html")
        if "assets" not in p.parts
    )


def _drawn(driver: Any) -> bool:
    """Whether the page's scripts are done: no diagram left as text."""
    script = "return document.querySelectorAll('pre.mermaid').length == 0"
    return bool(driver.execute_script(script))


PAGE_STATE = """
const hidden = (e) => e.closest('details:not([open])');
return {
  images: Array.from(document.images).filter(i => !hidden(i))
      .filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute('src')),
  plain_code: Array.from(document.querySelectorAll('article pre > code'))
      .filter(c => !c.closest('.highlight')).map(c => c.textContent.slice(0, 60)),
  diagrams: Array.from(document.querySelectorAll('div.mermaid'))
      .map(d => d.getBoundingClientRect().height),
  text: document.querySelector('article').innerText,
};
"""


def test_every_page_renders_offline(site: Path, served: str, browser: Any) -> None:
    from selenium.webdriver.support.ui import WebDriverWait

    shots = os.environ.get("MCS_SITE_SCREENSHOTS")
    problems: list[str] = []
    diagrams = 0
    for page in _pages(site):
        browser.get(f"{served}/{page.lstrip('/')}")
        WebDriverWait(browser, WAIT).until(_drawn)
        state = browser.execute_script(PAGE_STATE)
        errors = [e["message"] for e in browser.get_log("browser") if e["level"] == "SEVERE"]
        if errors:
            problems.append(f"{page}: console errors {errors}")
        if state["images"]:
            problems.append(f"{page}: images that did not load {state['images']}")
        if state["plain_code"]:
            problems.append(f"{page}: code blocks not highlighted {state['plain_code']}")
        flat = [h for h in state["diagrams"] if h < 50]
        if flat:
            problems.append(f"{page}: {len(flat)} diagram(s) not drawn")
        if "flowchart TD" in state["text"]:
            problems.append(f"{page}: a diagram shown as its source text")
        diagrams += len(state["diagrams"])
        if shots:
            Path(shots).mkdir(parents=True, exist_ok=True)
            name = page.strip("/").replace("/", "_") or "home"
            browser.save_screenshot(str(Path(shots) / f"{name}.png"))
    assert not problems, "\n".join(problems)
    assert diagrams >= 1  # the architecture's at least: drawn with the network cut off


def _search(browser: Any, served: str, query: str) -> list[str]:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    browser.get(f"{served}/")
    field = browser.find_element(By.CSS_SELECTOR, "input.md-search__input")
    browser.execute_script("document.querySelector('#__search').checked = true", field)
    field.send_keys(query)
    found = ".md-search-result__item > a"
    WebDriverWait(browser, WAIT).until(lambda d: d.find_elements(By.CSS_SELECTOR, found))
    links = browser.find_elements(By.CSS_SELECTOR, found)
    return [str(a.get_attribute("href")).removeprefix(served) for a in links]


@pytest.mark.parametrize(
    ("query", "expected"),
    [
        ("fidelity", "/concepts/fidelity/"),
        ("Foxglove", "/how-to/failing-runs/"),
        ("mcs_simulator", "/reference/pytest/"),
    ],
)
def test_search_finds_what_readers_look_for(
    served: str, browser: Any, query: str, expected: str
) -> None:
    results = _search(browser, served, query)
    assert expected in results[:5], results
