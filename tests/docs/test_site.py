"""The documentation site, built and opened in a browser as a reader would: ``mkdocs build --strict`` into a temporary
folder, served on localhost, every page opened in headless Chromium. A page fails when it does not load (an HTTP
status other than 200, no content, an error in the browser's console, such as a resource that did not load), when one
of its images did not load (``naturalWidth`` 0), or when one of its internal links points to a missing page or anchor.

The browser is Debian's Chromium driven by Selenium through Debian's chromedriver (packages ``chromium`` and
``chromium-driver``): the driver comes from the same Debian source as the browser, so their versions always match,
and nothing is downloaded at test time. Without them (or without mkdocs and selenium: ``pip install -e '.[docs]'``)
the test skips, unless ``WARPFREE_REQUIRE_BROWSER=1`` (CI sets it), where it fails instead."""

from __future__ import annotations

import functools
import http.server
import importlib.util
import os
import shutil
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path
from urllib.parse import urldefrag, urlparse

import pytest

from helpers import ROOT

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
#: how long a page's images may take to finish loading (s)
IMAGE_WAIT_S = 10.0


def missing_tools() -> list[str]:
    """What the test needs and this machine lacks."""
    missing = [f"the Python package {name} (pip install -e '.[docs]')" for name in ("mkdocs", "selenium")
               if importlib.util.find_spec(name) is None]
    missing += [f"{path} (apt-get install {package})" for path, package in
                ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")) if not shutil.which(path)]
    return missing


@pytest.fixture(scope="module")
def tools():
    missing = missing_tools()
    if missing:
        message = "the browser test needs " + "; ".join(missing)
        if os.environ.get("WARPFREE_REQUIRE_BROWSER") == "1":
            pytest.fail(message + " (WARPFREE_REQUIRE_BROWSER=1)")
        pytest.skip(message)


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # noqa: A002 - the base class's signature
        pass


@pytest.fixture(scope="module")
def site(tools, tmp_path_factory):
    """The site built strictly into a temporary folder and served on localhost: (base URL, folder)."""
    folder = tmp_path_factory.mktemp("site")
    built = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(folder)], cwd=ROOT,
                           capture_output=True, text=True, env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert built.returncode == 0, built.stderr[-4000:]
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(QuietHandler, directory=str(folder)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/", folder
    server.shutdown()
    server.server_close()


@pytest.fixture(scope="module")
def browser(tools):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                     "--window-size=1280,900"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(executable_path=CHROMEDRIVER))
    driver.set_page_load_timeout(30)
    yield driver
    driver.quit()


def page_urls(base: str, folder: Path) -> list[str]:
    """Every page of the built site (each ``index.html`` but MkDocs' 404 page), as URLs."""
    pages = sorted(p.relative_to(folder) for p in folder.rglob("index.html"))
    return [base + ("" if p.parent == Path(".") else p.parent.as_posix() + "/") for p in pages]


def http_status(url: str) -> int:
    try:
        with urllib.request.urlopen(url, timeout=10) as response:
            return response.status
    except urllib.error.HTTPError as err:
        return err.code


def open_page(driver, url: str) -> dict:
    """Load ``url`` and wait for its images; what the page showed: its console errors, its images that did not load,
    its internal links and the ids of its elements."""
    driver.get_log("browser")  # drop what earlier pages logged
    driver.get(url)
    deadline = time.monotonic() + IMAGE_WAIT_S
    while time.monotonic() < deadline and not driver.execute_script(
            "return document.readyState === 'complete' && Array.from(document.images).every(i => i.complete)"):
        time.sleep(0.1)
    return {
        "errors": [entry["message"] for entry in driver.get_log("browser") if entry["level"] == "SEVERE"],
        "broken_images": driver.execute_script(
            "return Array.from(document.images).filter(i => !i.complete || i.naturalWidth === 0).map(i => i.src)"),
        "images": driver.execute_script("return document.images.length"),
        "content": driver.execute_script("const a = document.querySelector('article'); "
                                         "return a ? a.innerText.trim().length : 0"),
        "links": driver.execute_script("return Array.from(document.querySelectorAll('a[href]')).map(a => a.href)"),
        "ids": driver.execute_script("return Array.from(document.querySelectorAll('[id]')).map(e => e.id)"),
    }


def test_every_page_loads_with_its_images_and_links(site, browser):
    base, folder = site
    urls = page_urls(base, folder)
    assert len(urls) >= 20, urls  # the nav's pages: a build that lost them fails here
    seen = {url: open_page(browser, url) for url in urls}
    problems, images = [], 0
    for url, page in seen.items():
        status = http_status(url)
        if status != 200:
            problems.append(f"{url}: HTTP {status}")
        if page["content"] == 0:
            problems.append(f"{url}: no content")
        problems += [f"{url}: console error: {message}" for message in page["errors"]]
        problems += [f"{url}: image did not load: {src}" for src in page["broken_images"]]
        images += page["images"]
        for link in page["links"]:
            target, anchor = urldefrag(link)
            if urlparse(target).netloc != urlparse(base).netloc:
                continue  # an external link: not this test's to follow (the site runs offline)
            if target not in seen:
                if http_status(target) != 200:
                    problems.append(f"{url}: link to a missing page: {link}")
                continue
            if anchor and anchor not in seen[target]["ids"]:
                problems.append(f"{url}: link to a missing anchor: {link}")
    assert not problems, "\n".join(problems)
    assert images >= 5  # the home page's picture, the gallery's: a site whose images all vanished fails here


def test_a_broken_image_and_a_missing_page_are_caught(site, browser, tmp_path):
    """The checks above can fail: a page with an image whose file is missing reports it, with its console error, and
    a missing page answers 404."""
    base, folder = site
    (folder / "broken").mkdir()
    (folder / "broken" / "index.html").write_text('<html><body><article>text<img src="../no-such-picture.png">'
                                                  '</article></body></html>', encoding="utf-8")
    page = open_page(browser, base + "broken/")
    assert page["broken_images"] and page["errors"]
    assert http_status(base + "no-such-page/") == 404
