"""The README stays short and its links lead somewhere; the docs site builds in strict mode, so a broken link,
a missing anchor or a page left out of the navigation fails here rather than on a reader."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def relative_links(text: str) -> list[str]:
    """The targets of the markdown links and images in `text` that point into the repository."""
    targets = [m.group(1) for m in LINK.finditer(text)]
    return [t for t in targets if not re.match(r"^[a-z][a-z0-9+.-]*:", t) and not t.startswith("#")]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("see [the CLI](docs/cli.md) and ![demo](docs/demo.png)", ["docs/cli.md", "docs/demo.png"]),
        ("[a section](docs/cli.md#exec)", ["docs/cli.md#exec"]),
        ("[paper](https://example.org/x.pdf) [mail](mailto:a@b.c) [here](#install)", []),
        ('[titled](docs/x.md "a title")', ["docs/x.md"]),
        ("no links at all", []),
    ],
)
def test_relative_links_are_read_from_markdown(text, expected):
    assert relative_links(text) == expected


def test_the_readme_is_short():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 300, f"README.md has {len(lines)} lines; move depth to a page under docs/"


def test_every_relative_link_in_the_readme_points_at_a_file():
    text = README.read_text(encoding="utf-8")
    links = relative_links(text)
    assert links, "the README links to the docs pages"
    missing = [t for t in links if not (ROOT / t.split("#", 1)[0]).exists()]
    assert not missing, f"README.md links to files that do not exist: {missing}"


def test_the_readmes_test_command_is_the_one_ci_runs():
    """`.ci/run` runs exactly the README's set-up-and-test command."""
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").strip().splitlines()[-1]
    assert f"    {ci}\n" in README.read_text(encoding="utf-8")


def test_the_docs_site_builds_in_strict_mode(tmp_path):
    if importlib.util.find_spec("mkdocs") is None:
        pytest.fail("mkdocs is not installed: pip install -e '.[test]'")
    build = [
        "build",
        "--strict",
        "--config-file",
        str(ROOT / "mkdocs.yml"),
        "--site-dir",
        str(tmp_path / "site"),
    ]
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", *build], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert (tmp_path / "site" / "index.html").is_file()
    assert (tmp_path / "site" / "results" / "index.html").is_file()
