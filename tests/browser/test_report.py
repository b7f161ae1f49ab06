"""`rayspace report --quick` in a real browser (headless Chromium through Selenium).

The page is served over HTTP from localhost as a user would open it; the test fails on any
console message of level SEVERE (script errors, missing files), on any image that did not
load, and when a number on the page differs from the JSON the benchmarks wrote.

A test that cannot run is not a pass: locally it prints ``SKIPPED: why`` and skips; in CI
(``CI=true``) it fails (`.ci/run` installs Chromium, ChromeDriver and Selenium).
"""

import functools
import http.server
import json
import os
import pathlib
import re
import shutil
import subprocess
import threading

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def need(ok, why):
    if ok:
        return
    if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
        pytest.fail(f"cannot run in CI: {why}", pytrace=False)
    print(f"SKIPPED: {why}")
    pytest.skip(why)


def slug(s):
    return "-".join(p for p in re.sub(r"[^a-z0-9]", "-", s.lower()).split("-") if p)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    b = os.environ.get("RAYSPACE_BIN", str(REPO / "target" / "release" / "rayspace"))
    need(os.access(b, os.X_OK), f"no rayspace binary at {b} (cargo build --release, or set RAYSPACE_BIN)")
    out = tmp_path_factory.mktemp("report") / "r"
    r = subprocess.run([b, "report", "--quick", "--out", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return out, json.loads((out / "report.json").read_text())


@pytest.fixture(scope="module")
def browser():
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        need(False, "selenium is not installed (pip install selenium)")
    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    driver = shutil.which("chromedriver") or "/usr/bin/chromedriver"
    need(os.access(chromium, os.X_OK), "no chromium (Debian: apt-get install chromium)")
    need(os.access(driver, os.X_OK), "no chromedriver (Debian: apt-get install chromium-driver)")
    opts = webdriver.ChromeOptions()
    opts.binary_location = chromium
    # Headless, and quiet on a closed network: no background connections that the
    # machine would refuse (they are not the page's errors).
    for a in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-dev-shm-usage",
        "--window-size=1300,1000",
    ):
        opts.add_argument(a)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    d = webdriver.Chrome(service=Service(driver), options=opts)
    yield d
    d.quit()


@pytest.fixture(scope="module")
def page(report, browser):
    out, data = report
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    handler = functools.partial(Quiet, directory=str(out))
    srv = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    browser.get(f"http://127.0.0.1:{srv.server_address[1]}/index.html")
    # Wait until the page and every image finished (loaded or failed).
    from selenium.webdriver.support.ui import WebDriverWait

    WebDriverWait(browser, 30).until(
        lambda d: d.execute_script(
            "return document.readyState === 'complete' && [...document.images].every(i => i.complete)"
        )
    )
    yield browser, data
    srv.shutdown()


def test_no_console_errors(page):
    browser, _ = page
    severe = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert severe == [], severe


def test_every_image_loaded(page):
    browser, data = page
    imgs = browser.execute_script(
        "return [...document.images].map(i => [i.getAttribute('src'), i.naturalWidth, i.naturalHeight])"
    )
    broken = [src for src, w, h in imgs if not (w > 0 and h > 0)]
    assert broken == [], broken
    srcs = {src for src, _, _ in imgs}
    # Renders, difference images, ray-kind thumbnails and charts are all on the page.
    for s in data["scenes"]:
        for r in s["renders"]:
            assert r["image"] in srcs
            assert r["diff_image"] is None or r["diff_image"] in srcs
        for k in s["ray_kinds"]:
            assert k["image"] in srcs
    assert data["charts"], data.get("charts_note")
    for _, f in data["charts"]:
        assert f in srcs


def test_numbers_match_the_json(page):
    browser, data = page
    from selenium.webdriver.common.by import By

    def text(id_):
        return browser.find_element(By.ID, id_).text.strip()

    checked = 0
    for s in data["scenes"]:
        for r in s["renders"]:
            base = f"render-{s['id']}-{slug(r['engine'])}"
            assert text(base + "-tests") == str(r["total_tests"])
            assert text(base + "-differing") == str(r["differing_pixels"])
            checked += 2
    for r in data["rsh"]:
        id_ = f"rsh-{slug(r['scene'])}-{r['engine']}-{r['objects']}-{r['branching']}-{r['levels']}-pct"
        assert abs(float(text(id_)) - r["percent_of_brute_force"]) <= 0.0005 + 1e-9, id_
        checked += 1
    # When a ray hierarchy pays: every scene's shadow rays by CRSH, RAH and bvh, hits
    # brute force's.
    pays = data["ray_hierarchy"]["rows"]
    assert {(r["kind"], r["engine"]) for r in pays} >= {("shadow", e) for e in ("crsh", "rah", "bvh")}
    for r in pays:
        id_ = f"pays-{slug(r['scene'])}-{r['kind']}-{r['engine']}"
        assert text(id_ + "-tests") == str(r["tests"]), id_
        assert abs(float(text(id_ + "-ns")) - r["ns_per_ray"]) <= 0.05 + 1e-9, id_
        assert r["wrong"] == 0 and r["rays"] > 0
        checked += 2
    assert all(c["crsh_tests"] > 0 and c["rah_tests"] > 0 for c in data["ray_hierarchy"]["claim"])
    for x in data["scaling"]["slopes"]:
        id_ = f"slope-{x['axis']}-{x['measure']}-{slug(x['engine'])}"
        assert abs(float(text(id_)) - x["slope"]) <= 0.005 + 1e-9, id_
        checked += 1
    assert checked > 50
    # The provenance line at the top names the commit the report was built from.
    assert data["commit"] in text("provenance")
