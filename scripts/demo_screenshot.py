"""Regenerates docs/demo.png: the live demo's page after it answered a query, as headless Chromium shows it.

Run: `.venv/bin/python scripts/demo_screenshot.py` (needs Debian's chromium and chromium-driver, and the
server and test extras: `scripts/install.sh --test`). The demo runs on a free port of 127.0.0.1 and stops
afterwards.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "docs" / "demo.png"
QUERY = "Which object is the heaviest?"


def main() -> int:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    from attribot.config import load_settings
    from attribot.demo import DemoConfig, create_app
    from attribot.server.run import ServerThread

    chromium, driver_path = shutil.which("chromium"), shutil.which("chromedriver")
    if not chromium or not driver_path:
        print(
            "needs chromium and chromedriver: sudo apt-get install chromium chromium-driver", file=sys.stderr
        )
        return 2
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        "--window-size=1400,1000",
    ):
        options.add_argument(flag)
    with tempfile.TemporaryDirectory() as runs:
        app = create_app(DemoConfig(settings=load_settings(), runs_dir=Path(runs)))
        with ServerThread(app) as server:
            browser = webdriver.Chrome(service=Service(driver_path), options=options)
            try:
                browser.get(server.url + "/")
                wait = WebDriverWait(browser, 300)
                wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, "#layout option"))
                query = browser.find_element(By.ID, "query")
                query.clear()
                query.send_keys(QUERY)
                browser.find_element(By.ID, "ask").click()
                wait.until(lambda d: d.find_element(By.ID, "status").text in ("answered", "no answer"))
                wait.until(
                    lambda d: d.execute_script("return document.getElementById('answer-image').complete")
                )
                height = browser.execute_script("return document.documentElement.scrollHeight")
                browser.set_window_size(1400, height)
                browser.execute_script("window.scrollTo(0, 0)")
                OUT.parent.mkdir(exist_ok=True)
                browser.save_screenshot(str(OUT))
            finally:
                browser.quit()
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
