"""License, citation and packaging metadata: CITATION.cff validates against the official Citation File Format
1.2.0 JSON schema (vendored in tests/data/), and agrees with the package's version, license and name."""

import copy
import json
import tomllib
from pathlib import Path

import jsonschema
import pytest
import yaml

import mutual

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = json.loads((ROOT / "tests" / "data" / "cff-1.2.0.schema.json").read_text())
CITATION = yaml.safe_load((ROOT / "CITATION.cff").read_text())
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def _errors(document):
    validator = jsonschema.Draft7Validator(SCHEMA, format_checker=jsonschema.Draft7Validator.FORMAT_CHECKER)
    return sorted(e.message for e in validator.iter_errors(document))


def test_the_schema_is_the_official_cff_1_2_0():
    assert SCHEMA["$id"] == "https://citation-file-format.github.io/1.2.0/schema.json"
    assert set(SCHEMA["required"]) == {"authors", "cff-version", "message", "title"}


def test_citation_cff_validates():
    assert _errors(CITATION) == []
    assert CITATION["cff-version"] == "1.2.0"


@pytest.mark.parametrize("break_it, phrase", [
    (lambda c: c.pop("authors"), "'authors' is a required property"),
    (lambda c: c.__setitem__("cff-version", "1.1.0"), "does not match"),
    (lambda c: c["preferred-citation"].__setitem__("type", "phd"), "is not one of"),
    (lambda c: c["preferred-citation"].__setitem__("month", 13), "is not valid under any of the given schemas"),
    (lambda c: c["preferred-citation"].pop("title"), "'title' is a required property"),
    (lambda c: c.__setitem__("license", "MIT-ish"), "is not valid under any of the given schemas"),
])
def test_the_schema_check_catches_a_broken_citation(break_it, phrase):
    broken = copy.deepcopy(CITATION)
    break_it(broken)
    errors = _errors(broken)
    assert errors and any(phrase in e for e in errors), errors


def test_the_preferred_citation_is_the_thesis():
    thesis = CITATION["preferred-citation"]
    assert thesis["type"] == "thesis"
    assert thesis["authors"][0]["family-names"] == "McPherson"
    assert thesis["year"] == 2022
    assert "Berkeley" in thesis["institution"]["name"]
    assert thesis["title"].startswith("Towards Mutual Understanding between Mortals and Machines")


def test_citation_license_and_package_metadata_agree():
    project = PYPROJECT["project"]
    assert CITATION["version"] == project["version"] == mutual.__version__
    assert CITATION["license"] == "MIT" and project["license"] == {"text": "MIT"}
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    assert project["name"] != "mutual"        # taken on PyPI by an unrelated project
    assert project["scripts"] == {"mutual": "mutual.cli:main"}


def test_runtime_dependencies_have_compatible_bounds_and_the_lock_pins_inside_them():
    from packaging.requirements import Requirement
    pins = {}
    for line in (ROOT / "environment.lock").read_text().splitlines():
        if "==" in line and not line.startswith((" ", "#")):
            name, version = line.split(" ")[0].split("==")
            pins[name.lower()] = version
    for text in PYPROJECT["project"]["dependencies"]:
        req = Requirement(text)
        ops = {spec.operator for spec in req.specifier}
        assert {">=", "<"} <= ops, f"{text}: needs a lower and an upper bound"
        assert req.specifier.contains(pins[req.name.lower()]), f"the lock's {req.name}=={pins[req.name.lower()]} " \
                                                               f"is outside {text}"
