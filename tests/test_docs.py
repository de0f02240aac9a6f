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


# -- the numbers in the pages, from the JSON the commands wrote ----------------------------------------------------
GENERATED = [page for page in PAGES if "<!-- numbers " in page.read_text(encoding="utf-8")]


def test_the_pages_that_discuss_the_papers_numbers_read_them_from_json():
    names = {page.relative_to(DOCS).as_posix() for page in GENERATED}
    assert {"paper.md", "discussion/remedies.md", "discussion/local-global.md"} <= names


@pytest.mark.parametrize("page", GENERATED, ids=[page.relative_to(DOCS).as_posix() for page in GENERATED])
def test_every_marked_number_is_what_its_json_gives(page):
    """The committed JSON (docs/data/*.json, written by the commands; test_paper and test_optimal hold it to a
    fresh run) is the page's source: writing the page again from it changes nothing."""
    from torqueopt.pages import render_page

    text = page.read_text(encoding="utf-8")
    assert render_page(text, page.parent) == text, (
        f"docs/{page.relative_to(DOCS)} is stale: python -m torqueopt.pages docs/{page.relative_to(DOCS)}"
    )


SOURCE = {
    "runs": [
        {"movement": "short", "resolver": "pinv", "peak": [13.04, 3.5412], "time": None, "ok": True},
        {"movement": "short", "resolver": "null-space", "peak": [0.7342, 3.19], "time": 1.38912, "ok": False},
        {"movement": "long", "resolver": "global weighted, bounded", "peak": [2.0, 1.0], "time": None, "ok": True},
    ],
    "share": -0.004,
    "error": 0.0002204,
}


@pytest.mark.parametrize(
    "expression, shown",
    [
        ("runs[movement=short,resolver=pinv].peak as .3g", "13, 3.54"),
        ("runs[movement=short, resolver=null-space].time as .3f", "1.389"),
        ("runs[movement=short,resolver=pinv].time as .3f", "-"),
        ("runs.1.peak.0 / runs.0.peak.0 as pct1", f"{100 * 0.7342 / 13.04:.1f} %"),
        ("runs.1.peak.0 / runs.0.peak.0 - 1 as pct", f"{round(100 * (0.7342 / 13.04 - 1))} %"),
        ("runs[resolver=global weighted, bounded].peak.0", "2.0"),
        ("share as pct", "0 %"),  # not "-0 %"
        ("error as mm", "0.22"),
        ("runs.0.ok as holds", "holds"),
        ("runs.1.ok as holds", "does not hold"),
        ("runs as count", "3"),
    ],
)
def test_a_marked_number_is_the_key_it_names_in_the_format_it_names(expression, shown):
    from torqueopt.pages import evaluate

    assert evaluate(SOURCE, expression) == shown


def test_a_page_is_written_from_its_source_and_its_mistakes_named(tmp_path, capsys):
    import json

    from torqueopt.errors import InvalidInput
    from torqueopt.pages import main, render_page, stale_pages

    (tmp_path / "data.json").write_text(json.dumps(SOURCE))
    page = tmp_path / "page.md"
    page.write_text(
        "<!-- numbers d: data.json -->\n"
        "pinv peaks at <!-- d:runs.0.peak.0 as .1f -->99<!-- / --> N·m.\n\n"
        "<!-- table d:runs[movement=short] ;; resolver ;; peak as .2g ;; /runs[resolver={resolver}].time as .2f -->\n"
        "| resolver | peak | when |\n| --- | --- | --- |\n| stale | row | here |\n<!-- /table -->\n"
    )
    assert stale_pages([page]) == [page]
    assert main([str(page)]) == 0 and stale_pages([page]) == []
    assert page.read_text().splitlines()[1:8] == [
        "pinv peaks at <!-- d:runs.0.peak.0 as .1f -->13.0<!-- / --> N·m.",
        "",
        "<!-- table d:runs[movement=short] ;; resolver ;; peak as .2g ;; /runs[resolver={resolver}].time as .2f -->",
        "| resolver | peak | when |",
        "| --- | --- | --- |",
        "| pinv | 13, 3.5 | - |",
        "| null-space | 0.73, 3.2 | 1.39 |",
    ]
    with pytest.raises(InvalidInput, match=r"'runs\[movement=medium\]' picks 0 rows of 'runs', not one"):
        render_page("<!-- numbers d: data.json -->\nx <!-- d:runs[movement=medium].time -->1<!-- / -->", tmp_path)
    with pytest.raises(InvalidInput, match="no key 'peaks' in 'runs.0.peaks'; the keys there are movement, "):
        render_page("<!-- numbers d: data.json -->\nx <!-- d:runs.0.peaks -->1<!-- / -->", tmp_path)
    with pytest.raises(InvalidInput, match=r"the page names no source 'e' \(<!-- numbers e: PATH -->\)"):
        render_page("<!-- numbers d: data.json -->\nx <!-- e:share -->1<!-- / -->", tmp_path)
    with pytest.raises(InvalidInput, match=r"'5' in 'runs.5.peak' is no index of a list of 3"):
        render_page("<!-- numbers d: data.json -->\nx <!-- d:runs.5.peak -->1<!-- / -->", tmp_path)
    with pytest.raises(InvalidInput, match="format 'percent' is neither a Python format specification for -0.004 "):
        render_page("<!-- numbers d: data.json -->\nx <!-- d:share as percent -->1<!-- / -->", tmp_path)
    with pytest.raises(InvalidInput, match="a marked number starts a line: '<!-- d:share -->1<!-- / -->'"):
        render_page("<!-- numbers d: data.json -->\n<!-- d:share -->1<!-- / --> x", tmp_path)
    page.write_text("<!-- numbers d: data.json -->\nx <!-- d:nothing -->1<!-- / -->\n")
    assert main([str(page)]) == 2
    assert capsys.readouterr().err == (
        f"torqueopt.pages: {page}: no key 'nothing' in 'nothing'; the keys there are runs, share, error\n"
    )
