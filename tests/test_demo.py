"""The live demo (`attribot demo`): its HTTP API on a real local server, and the page in a real browser
(Debian's chromium driven by selenium through chromium-driver), whose answer must equal `attribot ask
--json` for the same scene."""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import httpx
import pytest

from attribot.config import load_settings
from attribot.demo import DemoConfig, create_app, serve_demo
from attribot.demo.app import SECRET_HEADER
from attribot.errors import ConfigError
from attribot.server.run import ServerThread
from fakes.chat import serve_chat_replies

QUERY = "Which object is the closest to me?"


@pytest.fixture
def demo(tmp_path):
    app = create_app(DemoConfig(settings=load_settings(), runs_dir=tmp_path / "runs"))
    with ServerThread(app) as server:
        yield server


def _client(server) -> httpx.Client:
    """A browser-like client: the page sets its visitor cookie and gives it its secret, sent with posts."""
    client = httpx.Client(base_url=server.url, timeout=60)
    page = client.get("/")
    assert page.status_code == 200
    secret = re.search(r'<meta name="attribot-secret" content="([0-9a-f]+)">', page.text)
    assert secret is not None, "the page carries its secret"
    client.headers[SECRET_HEADER] = secret.group(1)
    return client


def _events(client, url) -> list[dict]:
    out = []
    with client.stream("GET", url, timeout=300) as reply:
        for line in reply.iter_lines():
            if line.startswith("data: "):
                out.append(json.loads(line[6:]))
    return out


def test_a_query_streams_its_program_calls_frames_and_answer_and_saves_the_run(demo, tmp_path):
    client = _client(demo)
    started = client.post("/api/runs", json={"query": "Which object is the closest?", "seed": "0"})
    assert started.status_code == 200, started.text
    # one query at a time per visitor: a second one while the first runs is refused, and says why
    again = client.post("/api/runs", json={"query": "Which object is the closest?"})
    assert again.status_code == 409 and "still running" in again.json()["message"]
    events = []
    with client.stream("GET", started.json()["events"], timeout=300) as reply:
        for line in reply.iter_lines():
            if line.startswith("data: "):
                events.append(json.loads(line[6:]))
                if events[-1]["type"] == "answer":  # a page fetches the answer's image as it arrives
                    assert client.get(events[-1]["image"]).status_code == 200
    kinds = [e["type"] for e in events]
    assert kinds[-1] == "done" and "error" not in kinds
    # the program comes before its calls, the calls before the answer, and camera frames arrive meanwhile
    assert kinds.index("program") < kinds.index("call") < kinds.index("answer")
    frames = [e for e in events if e["type"] == "frame"]
    assert frames and all(f["robot"].startswith("data:image/jpeg;base64,") for f in frames)
    answer_event = next(e for e in events if e["type"] == "answer")
    answer = answer_event["answer"]
    calls = [e for e in events if e["type"] == "call"]
    assert [c["call"] for c in calls] == [t["call"] for t in answer["trace"]]
    assert answer["object"]["category"] and answer["unit"] == "m"
    video = client.get(answer_event["video"])
    assert (
        video.status_code == 200
        and video.headers["content-type"] == "video/mp4"
        and len(video.content) > 10_000
    )
    saved = zipfile.ZipFile(io.BytesIO(client.get(answer_event["saved_run"]).content))
    names = {n.split("/")[-1] for n in saved.namelist()}
    assert {"answer.json", "program.py", "settings.json", "answer.png", "episode.mp4"} <= names
    kept = json.loads(saved.read(next(n for n in saved.namelist() if n.endswith("answer.json"))))
    assert kept["answer"] == answer["answer"]
    for name in saved.namelist():  # what a stranger downloads names no folder of the server's
        if name.endswith(".json"):
            text = saved.read(name).decode()
            assert str(Path.home()) + "/" not in text and str(tmp_path) not in text, name
    # another browser (no cookie of this visitor) cannot read this visitor's run
    other = _client(demo)
    assert other.get(answer_event["saved_run"]).status_code == 404


@pytest.mark.parametrize(
    "body, status, words",
    [
        ({"query": ""}, 400, "the query is empty"),
        ({"query": "Which is heaviest?", "layout": "nowhere"}, 400, "nowhere"),
        ({"query": "Which is heaviest?", "seed": "x"}, 400, "seed 'x' is not a whole number"),
        ({"query": "Which is heaviest?", "options": "grid"}, 400, "KEY=VALUE"),
        ({"query": "Which is heaviest?", "image": {"name": "a.png", "data": "%%%"}}, 400, "not valid base64"),
    ],
)
def test_bad_input_is_refused_with_a_message_and_its_fix(demo, body, status, words):
    reply = _client(demo).post("/api/runs", json=body)
    assert reply.status_code == status and words in reply.json()["message"] and reply.json()["fix"]


def test_an_error_while_answering_reaches_the_page_with_its_fix(demo):
    client = _client(demo)
    png = io.BytesIO()
    from PIL import Image

    Image.new("RGB", (32, 24), (200, 10, 10)).save(png, format="PNG")
    import base64

    image = {"name": "red.png", "data": base64.b64encode(png.getvalue()).decode()}
    started = client.post("/api/runs", json={"query": "Which object is red?", "image": image})
    assert started.status_code == 200
    events = _events(client, started.json()["events"])
    error = next(e for e in events if e["type"] == "error")
    assert "needs a real detector" in error["message"] and "--detector" in error["fix"]


def test_without_a_visitor_cookie_or_with_a_wrong_token_nothing_runs(tmp_path):
    app = create_app(DemoConfig(settings=load_settings(), runs_dir=tmp_path, token="s3cret"))
    with ServerThread(app) as server:
        plain = httpx.Client(base_url=server.url)
        assert plain.get("/").status_code == 401
        assert plain.get("/?token=wrong").status_code == 401
        assert plain.get("/api/options", headers={"Authorization": "Bearer s3cret"}).status_code == 200
        entered = plain.get("/?token=s3cret")  # the token is then kept in a cookie, and leaves the address
        assert entered.status_code == 303 and entered.headers["location"] == "/"
        assert "s3cret" not in entered.headers["set-cookie"]  # the cookie holds a value derived from it
        assert plain.get("/").status_code == 200
        assert plain.get("/api/options").json()["layouts"]
    app = create_app(DemoConfig(settings=load_settings(), runs_dir=tmp_path))
    with ServerThread(app) as server:
        reply = httpx.post(server.url + "/api/runs", json={"query": "Which is heaviest?"})
        assert reply.status_code == 400 and "visitor cookie" in reply.json()["message"]


def test_another_address_without_a_token_is_refused_before_listening(tmp_path):
    config = DemoConfig(settings=load_settings(), runs_dir=tmp_path)
    with pytest.raises(ConfigError, match="the demo would listen on 0.0.0.0 without a token") as refused:
        serve_demo(config, host="0.0.0.0", port=1)
    assert "ATTRIBOT_DEMO_TOKEN" in (refused.value.fix or "")


# ---- the page in a real browser --------------------------------------------------------------------


def _browser_or_skip() -> tuple[str, str]:
    chromium, driver = shutil.which("chromium"), shutil.which("chromedriver")
    if chromium and driver:
        return chromium, driver
    missing = " and ".join(n for n, p in (("chromium", chromium), ("chromium-driver", driver)) if not p)
    if os.geteuid() == 0 and shutil.which("apt-get"):
        # where scripts/install.sh --test runs as root with apt (CI), it installs both: never skip there
        pytest.fail(f"{missing} is missing although scripts/install.sh --test installs it as root")
    pytest.skip(f"Debian's {missing} is not installed (sudo apt-get install chromium chromium-driver)")


@pytest.fixture
def browser():
    chromium, driver_path = _browser_or_skip()
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--no-first-run",
    ):
        options.add_argument(flag)
    options.add_argument("--window-size=1400,1800")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(driver_path), options=options)
    try:
        yield driver
    finally:
        driver.quit()


def test_the_page_answers_a_typed_query_as_attribot_ask_json_does(demo, browser):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support import expected_conditions as ec
    from selenium.webdriver.support.ui import Select, WebDriverWait

    browser.get(demo.url + "/")
    wait = WebDriverWait(browser, 240)
    wait.until(lambda d: len(d.find_elements(By.CSS_SELECTOR, "#layout option")) == 3)
    Select(browser.find_element(By.ID, "layout")).select_by_value("household")
    seed = browser.find_element(By.ID, "seed")
    seed.clear()
    seed.send_keys("7")
    query = browser.find_element(By.ID, "query")
    query.clear()
    query.send_keys(QUERY)
    browser.find_element(By.ID, "ask").click()
    # the cameras show the episode while it runs
    wait.until(
        lambda d: (d.find_element(By.ID, "robot-camera").get_attribute("src") or "").startswith("data:")
    )
    wait.until(ec.visibility_of_element_located((By.ID, "answer-text")))
    shown = browser.find_element(By.ID, "answer-text").text
    status = browser.find_element(By.ID, "status").text
    program = browser.find_element(By.ID, "program").text
    calls = browser.find_elements(By.CSS_SELECTOR, "#calls li")
    page_json = json.loads(
        browser.execute_script("return document.getElementById('answer-json').textContent")
    )
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert not errors, errors
    assert status == "answered"

    cli = subprocess.run(
        [
            sys.executable,
            "-m",
            "attribot.cli",
            "ask",
            QUERY,
            "--layout",
            "household",
            "--seed",
            "7",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "NO_COLOR": "1"},
    )
    assert cli.returncode == 0, cli.stderr
    expected = json.loads(cli.stdout)
    assert shown == expected["answer"]
    assert page_json["object"] == expected["object"] and page_json["value"] == expected["value"]
    assert program.strip() == expected["program"].strip()
    assert len(calls) == len(expected["trace"])
    # the answer's image and the downloads are offered
    assert browser.find_element(By.ID, "answer-image").get_attribute("src").endswith("/answer.png")
    for link in ("download-video", "download-run"):
        href = browser.find_element(By.ID, link).get_attribute("href")
        assert httpx.get(href, cookies=browser_cookies(browser), timeout=60).status_code == 200


def browser_cookies(browser) -> dict[str, str]:
    return {c["name"]: c["value"] for c in browser.get_cookies()}


def test_the_page_says_a_refused_query_and_asks_again_afterwards(demo, browser):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    browser.get(demo.url + "/")
    wait = WebDriverWait(browser, 60)
    wait.until(lambda d: len(d.find_elements(By.CSS_SELECTOR, "#layout option")) == 3)
    browser.find_element(By.ID, "options").send_keys("grid")
    browser.find_element(By.ID, "ask").click()
    wait.until(lambda d: d.find_element(By.ID, "status").text.startswith("error:"))
    assert "'grid' is not KEY=VALUE" in browser.find_element(By.ID, "status").text
    assert browser.find_element(By.ID, "ask").is_enabled()
    # fixed, the same page asks again, twice: each answer replaces the last one's calls
    browser.find_element(By.ID, "options").clear()
    answers = []
    for text in ("Which object is the closest?", "Which object is the farthest?"):
        query = browser.find_element(By.ID, "query")
        query.clear()
        query.send_keys(text)
        browser.find_element(By.ID, "ask").click()
        WebDriverWait(browser, 240).until(lambda d: d.find_element(By.ID, "status").text == "answered")
        answers.append(browser.find_element(By.ID, "answer-text").text)
        page_json = json.loads(
            browser.execute_script("return document.getElementById('answer-json').textContent")
        )
        assert page_json["query"] == text
        assert len(browser.find_elements(By.CSS_SELECTOR, "#calls li")) == len(page_json["trace"])
    assert answers[0] != answers[1]
    time.sleep(0.2)
    # a 400 reply is logged by the browser as a failed resource; nothing else may be
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE" and "400" not in e["message"]]
    assert not errors, errors


def test_with_an_llm_endpoint_each_try_s_program_is_shown_and_the_answer_says_llm(tmp_path, httpserver):
    """The planner an `attribot demo --planner llm` runs with: a scripted OpenAI-compatible endpoint on
    127.0.0.1 whose first program fails, so that the page sees the second try too."""

    wrong = "def execute_command(image, robot):\n    return image.find('object')[99]\n"
    right = "def execute_command(image, robot):\n    return image.find('object')[0]\n"
    requests = serve_chat_replies(httpserver, [f"```python\n{wrong}```", f"```python\n{right}```"])
    settings = load_settings(
        planner="llm",
        llm_base_url=httpserver.url_for("/v1"),
        llm_model="test-model",
        cache_dir=tmp_path / "c",
    )
    app = create_app(DemoConfig(settings=settings, runs_dir=tmp_path / "runs"))
    with ServerThread(app) as server:
        client = _client(server)
        options = client.get("/api/options").json()
        assert options["llm_model"] == "test-model" and options["prompt"] == "attribot"
        started = client.post("/api/runs", json={"query": "Which object is the first one?"})
        events = _events(client, started.json()["events"])
    programs = [e for e in events if e["type"] == "program"]
    assert [p["text"] for p in programs] == [wrong, right] and [p["attempt"] for p in programs] == [1, 2]
    answer = next(e for e in events if e["type"] == "answer")["answer"]
    assert answer["planner"] == "llm" and answer["attempts"] == 2 and answer["error"] is None
    assert answer["prompt"] == "attribot"  # the answer names the prompt the model was shown
    assert answer["object"]["id"] and len(requests) == 2


def test_an_uploaded_image_is_answered_by_the_configured_detector(tmp_path, browser):
    """The page's other way in: an image file chosen in the page, with `--detector hf:...` (a tiny random
    OWLv2 saved to disk, loaded by path). What random weights find is arbitrary, so the answer is an
    object or the program's own error, shown as the answer; never a crash, and no episode video."""
    pytest.importorskip("transformers", reason="needs the models extra")
    from PIL import Image
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    from fakes.hf_random import save_random

    save_random("owlv2-tiny", tmp_path / "owl")
    photo = tmp_path / "photo.png"
    Image.new("RGB", (320, 240), (90, 120, 160)).save(photo)
    settings = load_settings(detector=f"hf:{tmp_path / 'owl'}")
    app = create_app(DemoConfig(settings=settings, runs_dir=tmp_path / "runs"))
    with ServerThread(app) as server:
        browser.get(server.url + "/")
        wait = WebDriverWait(browser, 240)
        wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, "#layout option"))
        browser.find_element(By.CSS_SELECTOR, "input[name=where][value=image]").click()
        assert not browser.find_element(By.ID, "layout").is_displayed()
        browser.find_element(By.ID, "image").send_keys(str(photo))
        query = browser.find_element(By.ID, "query")
        query.clear()
        query.send_keys("the leftmost item")
        browser.find_element(By.ID, "ask").click()
        wait.until(lambda d: d.find_element(By.ID, "status").text in ("answered", "no answer"))
        page_json = json.loads(
            browser.execute_script("return document.getElementById('answer-json').textContent")
        )
        assert page_json["backends"]["detector"].startswith("hf:")
        assert page_json["world"]["image"].endswith("upload.png")
        assert page_json["trace"] and page_json["trace"][0]["call"].startswith("ImagePatch.")
        assert not browser.find_element(By.ID, "download-video").is_displayed()  # a still image has none
        assert browser.find_element(By.ID, "download-run").is_displayed()
        errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
        assert not errors, errors
