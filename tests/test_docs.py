"""The documentation site covers what it must: every public name, every guide page, every tutorial.

The build itself (Sphinx with warnings as errors, so a broken cross-reference fails) runs in `.ci/run`,
and, with the dummy builder, in the last test here (skipped without the docs extra); the other
checks read the sources, so they need no Sphinx and run in the core install too.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

import torqueopt

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
API = (DOCS / "api.md").read_text(encoding="utf-8")
EXAMPLES = sorted(path.name for path in (ROOT / "examples").glob("*.py"))
PAGES = sorted(path for path in DOCS.rglob("*.md") if "_build" not in path.parts and path.name != "README.md")


@pytest.mark.parametrize("name", torqueopt.__all__)
def test_the_api_reference_documents_every_public_name(name):
    directives = re.findall(r"^\.\. auto(?:function|class|exception|module|data):: (\S+)", API, re.M)
    assert f"torqueopt.{name}" in directives, f"docs/api.md has no autodoc directive for torqueopt.{name}"


def test_the_guide_folder_is_in_the_site_by_a_glob():
    index = (DOCS / "index.md").read_text(encoding="utf-8")
    guide = (DOCS / "guide" / "index.md").read_text(encoding="utf-8")
    assert "guide/index" in index
    assert re.search(r"```\{toctree\}\n(:[^\n]*\n)*:glob:\n(:[^\n]*\n)*\n\*\n```", guide), guide


def test_every_atlas_report_is_in_the_site():
    atlas = (DOCS / "discussion" / "atlas.md").read_text(encoding="utf-8")
    for report in sorted((DOCS / "atlas").glob("*.md")):
        assert f"../atlas/{report.stem}\n" in atlas, report.name


@pytest.mark.parametrize("script", EXAMPLES)
def test_every_example_is_a_tutorial_on_the_site_and_runs_in_the_tests(script):
    tutorials = (DOCS / "tutorials.md").read_text(encoding="utf-8")
    assert f"```{{literalinclude}} ../examples/{script}\n" in tutorials
    anchor = "tutorials.md#" + script.replace("_", "-").replace(".py", "-py")
    assert any(anchor in page.read_text(encoding="utf-8") for page in PAGES if page.name != "tutorials.md"), (
        f"no page links to the tutorial {script} ({anchor})"
    )
    assert f'"{script}"' in (ROOT / "tests" / "test_examples.py").read_text(encoding="utf-8")


#: The pages that teach, each with the tutorial that goes with it.
TEACHING = ["getting-started.md", "paper.md", "running.md", "paths.md", "dexterity.md", "playback.md", "robots.md",
            "discussion/remedies.md", "discussion/bounds.md", "discussion/kinematic.md",
            "discussion/local-global.md", "discussion/atlas.md"]  # fmt: skip


@pytest.mark.parametrize("page", TEACHING)
def test_every_page_that_teaches_links_to_its_tutorial(page):
    text = (DOCS / page).read_text(encoding="utf-8")
    linked = re.findall(r"\(\.*/?(?:\.\./)?tutorials\.md#([a-z-]+)-py\)", text)
    assert linked, f"docs/{page} links to no tutorial"
    assert {name.replace("-", "_") + ".py" for name in linked} <= set(EXAMPLES)


def test_the_site_builds_without_a_warning(tmp_path):
    """The build `.ci/run` does, with Sphinx's dummy builder (every page read and every reference resolved,
    no HTML written: about 4 s of CPU), in the quick selection, so that a docstring's broken cross-reference
    fails before it lands. Skips in the core install, which has no Sphinx."""
    pytest.importorskip("sphinx", reason="the docs extra is not installed")
    pytest.importorskip("myst_parser", reason="the docs extra is not installed")
    pytest.importorskip("furo", reason="the docs extra is not installed")
    process = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "dummy", str(DOCS), str(tmp_path / "out"),
         "-d", str(tmp_path / "doctrees")],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert process.returncode == 0, (
        "the docs do not build. A reference to a torqueopt object that is not documented: add the object to "
        "docs/modules.md (or docs/api.md if it is in torqueopt.__all__), or write the name as ``code``.\n"
        + process.stderr
    )
