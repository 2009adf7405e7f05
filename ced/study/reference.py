"""The generated reference pages of the documentation: scene, study config, dataset.

Each page is rendered from the definitions the code validates and writes with, so it cannot
drift from them: the scene spec (:func:`ced.problem.reference.scene_reference`), the study
config's JSON schema (:func:`config_reference`, from :data:`ced.study.config.SCHEMA_PATH`) and
the dataset registry (:func:`ced.simulation.dataset.dataset_reference`).

``make reference`` writes them (with the command-line reference, :func:`ced.cli.write_references`); ``tests/test_docs_reference.py``
fails when the committed pages differ from freshly generated ones, and when a key or variable
has no one-line meaning.
"""
from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

from ..problem.reference import markdown_table, scene_reference
from ..simulation.dataset import dataset_reference
from .config import SCHEMA_PATH

__all__ = ["config_reference", "config_rows", "REFERENCES", "write_references"]

_WORDS = {"number": "a number", "integer": "an integer", "string": "a string",
          "array": "a list", "object": "a mapping", "boolean": "true or false"}
_PLURAL = {"number": "numbers", "integer": "integers", "string": "strings", "array": "lists",
           "object": "mappings", "boolean": "booleans"}


def _schema() -> dict:
    import yaml

    return yaml.safe_load(SCHEMA_PATH.read_text(encoding="utf-8"))


def _resolve(node: dict, schema: dict) -> dict:
    """``node`` with a local ``$ref`` merged in (the node's own keys win)."""
    ref = node.get("$ref")
    if not ref:
        return node
    target = schema
    for part in ref.removeprefix("#/").split("/"):
        target = target[part]
    return {**target, **{k: v for k, v in node.items() if k != "$ref"}}


def _allowed(node: dict, schema: dict) -> str:
    """Allowed values of a schema node in words."""
    ref = node.get("$ref")
    if ref:
        target = _resolve({"$ref": ref}, schema)
        return target["description"].strip()
    if "enum" in node:
        return "one of " + ", ".join(str(v) for v in node["enum"])
    if "oneOf" in node:
        return " or ".join(_allowed(sub, schema) for sub in node["oneOf"])
    kind = node.get("type", "")
    text = _WORDS.get(kind, kind or "any value")
    bounds = [f"{op} {node[key]:g}" for key, op in
              (("exclusiveMinimum", ">"), ("minimum", ">="), ("exclusiveMaximum", "<"),
               ("maximum", "<=")) if key in node]
    if bounds:
        text += " " + " and ".join(bounds)
    if kind == "array":
        items = node.get("items", {})
        if "enum" in items:
            text += " of " + ", ".join(str(v) for v in items["enum"])
        elif "oneOf" in items:
            text += " of " + " or ".join(_PLURAL[sub["type"]] for sub in items["oneOf"])
        elif "type" in items:
            text += " of " + _PLURAL[items["type"]]
        if node.get("minItems"):
            text += ", not empty"
        if node.get("uniqueItems"):
            text += ", no repeats"
    if "pattern" in node:
        text += f" matching `{node['pattern']}`"
    return text


def _default(node: dict, required: bool) -> str:
    if required:
        return "required"
    if "default" not in node:
        return "none"
    value = node["default"]
    if isinstance(value, list):
        return "`[" + ", ".join(str(v) for v in value) + "]`"
    if isinstance(value, dict):
        return "`{}`" if not value else f"`{value}`"
    return f"`{value}`"


def config_rows() -> list[list[str]]:
    """Every key of the study-config schema as ``[key, allowed values, default, meaning]``.

    Raises
    ------
    KeyError
        If a property of the schema has no ``description``: every key must have one.
    """
    schema = _schema()
    rows: list[list[str]] = []

    def walk(properties: dict, required: list, prefix: str) -> None:
        for name, node in properties.items():
            key = f"{prefix}{name}"
            full = _resolve(node, schema)
            description = " ".join(node["description"].split()) if "description" in node \
                else " ".join(full["description"].split())
            rows.append([key, _allowed(node, schema), _default(node, name in required),
                         description])
            if full.get("type") == "object" and "properties" in full and "$ref" not in node \
                    and name != "base_scene":
                walk(full["properties"], full.get("required", []), f"{key}.")
            for branch in [] if "$ref" in node else full.get("oneOf", []):  # convergence
                if branch.get("type") == "object" and "properties" in branch:
                    walk(branch["properties"], branch.get("required", []), f"{key}.")

    walk(schema["properties"], schema.get("required", []), "")
    return rows


def config_reference() -> str:
    """The study-config reference page (Markdown), from the JSON schema.

    Returns
    -------
    str
        The text of ``docs/reference/config.md``, ending with a newline.
    """
    schema = _schema()
    parts = [
        "# Study-config reference",
        "",
        "<!-- Generated by `make reference` from "
        "`workflow/schemas/config.schema.yaml`; do not edit by hand "
        "(`tests/test_docs_reference.py` fails when this page is out of date). -->",
        "",
        " ".join(schema["description"].split()),
        "",
        "A study config is YAML read as Snakemake reads it (YAML 1.1: write exponents with a dot "
        "and a signed exponent, `1.0e-3`, `2.1e+11`). Run a study with "
        "`.venv/bin/snakemake --profile workflow/profiles/default --configfile CONFIG`; check "
        "it first with `ced check CONFIG`.",
        "",
        markdown_table(["key", "allowed values", "default", "meaning"], config_rows()),
        "",
        "Beyond the schema, `ced check` and the pipeline refuse non-finite numbers, repeated "
        "grid values or material names, a grid with no assemblable geometry of the families "
        "kept, a base scene that is not a valid scene, and studies whose estimated size is "
        "beyond the limits of `ced.study.config` (grid points, output bytes, memory).",
        "",
    ]
    return "\n".join(parts)


#: File name -> generator of each reference page.
REFERENCES: dict[str, Callable[[], str]] = {
    "scene.md": scene_reference,
    "config.md": config_reference,
    "dataset.md": dataset_reference,
}


def write_references(directory: str | Path) -> list[Path]:
    """Write every reference page into ``directory``; return the paths written.

    Parameters
    ----------
    directory : str or Path
        Target folder (``docs/reference``), created if missing.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for name, make in REFERENCES.items():
        path = directory / name
        path.write_text(make(), encoding="utf-8")
        written.append(path)
    return written


def _main(argv: list[str]) -> int:
    target = argv[0] if argv else "docs/reference"
    for path in write_references(target):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(_main(sys.argv[1:]))
