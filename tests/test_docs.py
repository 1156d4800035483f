"""The documentation's contracts that the Sphinx build (run by the README's test command with
``-W``) does not check by itself: the API reference lists every public name, the README's links
into the repository hold (files and #anchors), the built site has no broken internal link, the
guide's Python blocks run, and the test command stays one line that lints and builds the docs."""

from __future__ import annotations

import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import rvflex

ROOT = Path(__file__).resolve().parents[1]


def test_api_reference_lists_every_public_name():
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    documented = set(re.findall(r"^\.\. auto(?:function|class):: (\w+)$", text, re.M))
    public = {n for n in rvflex.__all__ if not n.startswith("__")}
    assert public - documented == set(), "public names missing from docs/api.md"
    assert documented - public == set(), "docs/api.md documents names that are not public"


def _anchors(markdown: Path) -> set[str]:
    """The heading anchors of a markdown page as MyST (and GitHub) make them."""
    from myst_parser.slugs import github_slugify

    text = re.sub(r"```.*?```", "", markdown.read_text(encoding="utf-8"), flags=re.S)  # no headings in code
    return {github_slugify(re.sub(r"[`*]", "", h).strip()) for h in re.findall(r"^#{1,6} (.+)$", text, re.M)}


def test_readme_links_into_the_repository_exist():
    """Every relative link of the README (the front page on GitHub, not a site page) names an
    existing file, and its #anchor a heading of that page."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    targets = [t for t in re.findall(r"\]\(([^)\s]+)\)", text) if not re.match(r"[a-z]+:", t)]
    assert len(targets) >= 10  # the front page links into the docs
    missing = [t for t in targets if not (ROOT / t.split("#")[0]).exists()]
    assert not missing, f"README.md links to missing files: {missing}"
    bad = [t for t in targets if "#" in t and t.split("#")[1] not in _anchors(ROOT / t.split("#")[0])]
    assert not bad, f"README.md links to missing headings: {bad}"


class _Links(HTMLParser):
    """The ids a page defines and the relative links (href/src) it makes."""

    def __init__(self):
        super().__init__()
        self.ids: set[str] = set()
        self.links: list[str] = []

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name in ("id", "name") and value:
                self.ids.add(value)
            if name in ("href", "src") and value and tag in ("a", "img", "link", "script", "source", "iframe"):
                self.links.append(value)


def broken_links(site: Path) -> list[str]:
    """``page: link`` for every internal link of the built HTML site ``site`` whose file is missing,
    or whose #fragment is no id of its target page. External links (a scheme, ``//host``) are
    not followed: CI has no network. ``_static/`` and ``_sources/`` hold no pages."""
    pages = {}
    for page in site.rglob("*.html"):
        if page.relative_to(site).parts[0] in ("_static", "_sources"):
            continue  # the theme's templates and the page sources: not pages of the site
        parser = _Links()
        parser.feed(page.read_text(encoding="utf-8"))
        pages[page.resolve()] = parser
    broken = []
    for page, parser in sorted(pages.items()):
        for link in parser.links:
            url = urlsplit(link)
            if url.scheme or url.netloc:
                continue
            target = (page.parent / unquote(url.path)).resolve() if url.path else page
            if target.is_dir():
                target = target / "index.html"
            if not target.exists() or site.resolve() not in target.parents:
                broken.append(f"{page.relative_to(site.resolve())}: {link} (no such file)")
            elif url.fragment and target.suffix == ".html" and unquote(url.fragment) not in pages[target].ids:
                broken.append(f"{page.relative_to(site.resolve())}: {link} (no such anchor)")
    return broken


def test_the_link_check_sees_a_missing_page_and_a_missing_anchor(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "index.html").write_text('<a href="sub/a.html#ok">a</a> <a href="b.html">b</a> '
                                         '<a href="sub/a.html#gone">c</a> <img src="_images/x.png"> '
                                         '<a href="https://example.org/x.html">external</a> <a href="#top">top</a>'
                                         '<p id="top"></p>')
    (tmp_path / "sub" / "a.html").write_text('<h1 id="ok">A</h1><a href="../index.html#top">back</a>')
    assert broken_links(tmp_path) == ["index.html: b.html (no such file)", "index.html: sub/a.html#gone (no such anchor)",
                                      "index.html: _images/x.png (no such file)"]


def test_the_site_has_no_broken_internal_link(tmp_path):
    """Build the site (the gallery's scripts not run: the -W build of the test command runs them)
    and follow every internal link, image and stylesheet of every page, #anchors included."""
    build = subprocess.run([sys.executable, "-m", "sphinx", "-q", "-b", "html", "-D", "plot_gallery=0",
                            str(ROOT / "docs"), str(tmp_path / "html")], capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    pages = list((tmp_path / "html").rglob("*.html"))
    assert len(pages) >= 15 and (tmp_path / "html" / "gallery" / "index.html").exists()
    broken = broken_links(tmp_path / "html")
    assert not broken, "broken links on the site:\n" + "\n".join(broken)


def _python_blocks(page: Path) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", page.read_text(encoding="utf-8"), re.S | re.M)


def test_the_python_guides_own_blocks_run(tmp_path, monkeypatch):
    """docs/python.md's ```python blocks, each as written (the README's blocks it includes run in
    tests/test_api.py)."""
    monkeypatch.chdir(tmp_path)
    blocks = _python_blocks(ROOT / "docs" / "python.md")
    assert blocks and all("import rvflex" in b for b in blocks)
    for k, block in enumerate(blocks):
        namespace: dict = {}
        exec(compile(block, f"docs/python.md, block {k + 1}", "exec"), namespace)
    assert namespace["design"].factors[0].levels == (-2e-6, 2e-6)


def test_ci_test_command_is_one_line_that_lints_and_builds_the_docs():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- ci:test -->\s*```bash\n(.*?)```", text, re.S).group(1).strip()
    assert "\n" not in block
    assert "ruff check" in block and "sphinx -W" in block and block.endswith("-m pytest")
    assert '".[test,docs]"' in block
