"""The documentation's contracts that the Sphinx build (run by the README's test command with
``-W``) does not check by itself: the API reference lists every public name, the README's links
into the repository hold, and the test command stays one line that lints and builds the docs."""

from __future__ import annotations

import re
from pathlib import Path

import rvflex

ROOT = Path(__file__).resolve().parents[1]


def test_api_reference_lists_every_public_name():
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    documented = set(re.findall(r"^\.\. auto(?:function|class):: (\w+)$", text, re.M))
    public = {n for n in rvflex.__all__ if not n.startswith("__")}
    assert public - documented == set(), "public names missing from docs/api.md"
    assert documented - public == set(), "docs/api.md documents names that are not public"


def test_readme_links_into_the_repository_exist():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    targets = [t for t in re.findall(r"\]\(([^)\s]+)\)", text) if not re.match(r"[a-z]+://", t)]
    assert len(targets) >= 10  # the front page links into the docs
    missing = [t for t in targets if not (ROOT / t.split("#")[0]).exists()]
    assert not missing, f"README.md links to missing files: {missing}"


def test_ci_test_command_is_one_line_that_lints_and_builds_the_docs():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- ci:test -->\s*```bash\n(.*?)```", text, re.S).group(1).strip()
    assert "\n" not in block
    assert "ruff check" in block and "sphinx -W" in block and block.endswith("-m pytest")
    assert '".[test,docs]"' in block
