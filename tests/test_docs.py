"""The documentation runs and cannot drift: README and docs/ snippets, the schema tables, the artifact keys,
the README's size and index, line lengths and links."""

import re
from pathlib import Path

import pytest
from slipnav.scenarios import schema
from slipnav.scenarios.config import scenario_from_yaml
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.cli import main

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()
DOCS = ROOT / "docs"


def _blocks(text: str, language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", text, re.S)


PYTHON_DOCUMENTS = {"README.md": 1, "docs/python-api.md": 1, "docs/truth-and-belief.md": 1}
"""The documents with Python examples and how many each has: README's three-line example, the worked
scripts of docs/python-api.md and docs/truth-and-belief.md (a Truth and a Belief)."""
PYTHON_BLOCKS = [
    (document, index)
    for document in PYTHON_DOCUMENTS
    for index in range(len(_blocks((ROOT / document).read_text(), "python")))
]


@pytest.mark.parametrize("document, index", PYTHON_BLOCKS)
def test_python_blocks_run(document, index, capsys):
    code = _blocks((ROOT / document).read_text(), "python")[index]
    namespace = {}
    exec(compile(code, f"{document} python block {index}", "exec"), namespace)
    if "arrays" in namespace:  # the three-line example
        assert len(namespace["arrays"]["t"]) == 751  # 1.5 s on the 2 ms grid
    else:  # the worked script prints how far the fused estimate ends from the truth
        assert re.search(r"fused estimate ends \d+\.\d mm from the truth", capsys.readouterr().out)


def test_python_blocks_exist():
    for document, count in PYTHON_DOCUMENTS.items():
        assert len(_blocks((ROOT / document).read_text(), "python")) == count, document
    assert "arrays = run_scenario(" in _blocks(README, "python")[0]
    assert "fused estimate ends" in _blocks((DOCS / "python-api.md").read_text(), "python")[0]


YAML_DOCUMENTS = [
    "docs/scenario-schema.md",
    "docs/model.md",
    "docs/calibration.md",
    "docs/truth-and-belief.md",
    "docs/sensor-faults.md",
]
"""The documents with YAML examples (scenarios or calibration sessions), each loaded as written."""


def test_every_document_with_yaml_examples_is_checked():
    for path in [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]:
        if _blocks(path.read_text(), "yaml"):
            assert str(path.relative_to(ROOT)) in YAML_DOCUMENTS, path


@pytest.mark.parametrize("document", YAML_DOCUMENTS)
def test_every_yaml_example_loads(document):
    blocks = _blocks((ROOT / document).read_text(), "yaml")
    assert blocks
    for block in blocks:
        if "manoeuvres:" in block:  # a calibration session (docs/calibration.md)
            from slipnav.scenarios.typed_yaml import check_schema, load_yaml
            from slipnav.studies.calibration_session import CalibrationSession

            check_schema(CalibrationSession, load_yaml(block), "")
            continue
        scenario_from_yaml(block, name="example")


def test_schema_doc_is_generated_from_the_dataclasses():
    text = (DOCS / "scenario-schema.md").read_text()
    assert schema.generated_section() in text, (
        "run: python -m slipnav.scenarios.schema --write docs/scenario-schema.md"
    )
    keys = [row[0] for row in schema.key_rows()]
    for key in [
        "navigation.ekf.Q",
        "navigation.yaw_calibration.enabled",
        "plant.deviations.wheel_radius_R",
        "plant.tolerances.accel1_misalignment_deg",
        "follower.k2",
        "slip_control.k_s",
        "name",
    ]:
        assert key in keys
    for key in keys + [row[0] for row in schema.segment_rows() + schema.override_rows()]:
        assert f"`{key}`" in text, key


def test_artifact_doc_lists_every_npz_and_summary_key():
    result = run_scenario(
        scenario_from_yaml("trajectory:\n  segments:\n    - !Straight {length: 0.1, v_end: 0.5}\n"),
        duration=0.1,
    )
    text = (DOCS / "artifacts.md").read_text()
    for key in list(result.arrays) + list(result.summary):
        assert f"`{key}`" in text, key


def test_docs_point_into_the_repository(capsys):
    for text in [README] + [p.read_text() for p in DOCS.glob("*.md")]:
        assert "../shared" not in text.replace("`../shared/DESIGN.md`", "")
    for name in ("design.md", "artifacts.md", "scenario-schema.md"):
        assert f"docs/{name}" in README and (DOCS / name).is_file()
    with pytest.raises(SystemExit):
        main(["--help"])
    help_text = capsys.readouterr().out
    assert "docs/design.md" in help_text and "docs/artifacts.md" in help_text


def test_schema_doc_names_every_key_where_inf_means_something():
    from slipnav.scenarios.config import INFINITY_ALLOWED

    header = (DOCS / "scenario-schema.md").read_text().split("## Ranges checked across keys")[0]
    for key in sorted(INFINITY_ALLOWED):
        assert f"`{key}`" in header, key


README_MAX_LINES = 250
MAX_LINE_LENGTH = 200


def _documentation_index() -> str:
    start = README.index("\n## Documentation\n")
    end = README.find("\n## ", start + 1)
    return README[start : end if end >= 0 else len(README)]


def test_readme_is_a_short_manual():
    assert len(README.splitlines()) <= README_MAX_LINES


@pytest.mark.parametrize("document", ["README.md", *sorted(p.name for p in DOCS.glob("*.md"))])
def test_no_line_is_longer_than_the_limit(document):
    path = ROOT / document if document == "README.md" else DOCS / document
    long = [i for i, line in enumerate(path.read_text().splitlines(), 1) if len(line) > MAX_LINE_LENGTH]
    assert not long, f"{document}: lines {long} exceed {MAX_LINE_LENGTH} characters"


def test_the_readme_indexes_every_document():
    linked = set(re.findall(r"\]\(docs/([^)#]+\.md)\)", _documentation_index()))
    assert linked, "README.md has no ## Documentation index"
    for name in linked:
        assert (DOCS / name).is_file(), f"README's index links docs/{name}, which does not exist"
    for path in DOCS.glob("*.md"):
        assert path.name in linked, f"docs/{path.name} is not in README's ## Documentation index"


def test_relative_links_resolve():
    for path in [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]:
        for target in re.findall(r"\]\(([^)\s]+)\)", path.read_text()):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue  # a URL or an anchor in the same page
            assert (path.parent / target.split("#")[0]).exists(), f"{path.name}: {target}"
