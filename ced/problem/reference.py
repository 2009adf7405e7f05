"""The scene reference of the documentation, generated from the scene's declarative spec.

:func:`scene_reference` renders every scene key — its allowed values, unit, default and one
line of meaning — as Markdown, from the very objects that validate scenes
(:data:`ced.problem.scene.BLOCKS`, :data:`~ced.problem.scene.MECHANISM_FIELDS`,
:data:`~ced.problem.scene.MEANINGS`, :data:`~ced.problem.materials.MATERIAL_FIELDS`, …), so
the page cannot drift from the code: ``docs/reference/scene.md`` is its output, and
``tests/test_docs_reference.py`` fails when the committed page differs from a fresh one.

:func:`markdown_table` is shared with the dataset and study-config references.

Examples
--------
>>> print(markdown_table(["key", "unit"], [["drive.speed", "rad/s"]]))
| key | unit |
|---|---|
| `drive.speed` | rad/s |
"""
from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from typing import Any

from .errors import Choice, Real
from .linkage import DYAD_KEYS, DYAD_MEANINGS
from .materials import MATERIAL_FIELDS, SECTION_FIELDS, SECTION_SHAPES, material_aliases, \
    material_names
from .mechanism import topology
from .scene import (BLOCKS, BUILTIN_LINK, DEFAULT_EFFECTS, DEFAULT_GRAVITY, DEFAULT_TOLERANCE,
                    EFFECTS, MECHANISM_FIELDS, MECHANISM_TYPES, MEANINGS, MODEL_PARAMETERS,
                    NAME_CHECK, POINT_MASS_CHECK, REQUIRED, TOLERANCE_CHECK)

__all__ = ["scene_reference", "markdown_table", "scene_rows", "RPR_EXAMPLE"]

#: The worked RPR example of the scene reference (a scene ``tests/test_docs_reference.py``
#: loads).
RPR_EXAMPLE = """\
mechanism:
  type: linkage
  ground: {A: [0.0, 0.0], O: [0.0, -0.25]}
  input: {link: crank, pivot: A, tip: B, length: 0.1}
  dyads:
    - {kind: RPR, links: [lever, block], joints: [O, C, B], lengths: [0.45],
       offset: 0.0, sleeve_mass: 0.4, sleeve_inertia: 3.0e-4}
    - {kind: RRP, links: [rod, ram], joints: [C, F], lengths: [0.15],
       guide: {point: [0.0, 0.22], angle: 0.0}, slider_mass: 2.0}
links:
  crank: {flexible: true}
  rod: {flexible: true}
"""

_BLOCK_TITLES = {
    "drive": "How the input link is driven.",
    "damping": "Structural damping (used only when `damping` is in `effects`).",
    "discretization": "The finite-element model of the flexible links "
                      "(or the string `auto`: elements and steps chosen for `tolerance`).",
    "time": "Time integration.",
    "modal": "Natural frequencies over the cycle (the block present, even empty `{}`, asks for "
             "them; absent or `null`: no modal analysis).",
    "outputs": "What is written.",
}


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """A Markdown (MyST/GFM) pipe table; the first column is set as code.

    Parameters
    ----------
    header : sequence of str
        Column titles.
    rows : iterable of sequences of str
        One sequence of cells per row; ``|`` in a cell is escaped.

    Returns
    -------
    str
        The table, one line per row, without a trailing newline.
    """
    def cell(text: str) -> str:
        # Outside code spans, "<" would start raw HTML (results/<study>/ would vanish).
        parts = str(text).replace("|", "\\|").replace("\n", " ").split("`")
        return "`".join(p if i % 2 else p.replace("<", "\\<") for i, p in enumerate(parts))

    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        first, *rest = row
        code = "`" + str(first).replace("|", "\\|") + "`"
        lines.append("| " + " | ".join([code] + [cell(c) for c in rest]) + " |")
    return "\n".join(lines)


def _value(value: Any) -> str:
    """A default as it is written in YAML."""
    if value is REQUIRED or value == "required":
        return "required"
    if value is None:
        return "none"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f"`{value}`" if value else '`""`'
    if isinstance(value, (list, tuple)):
        return "`[" + ", ".join(str(v) for v in value) + "]`"
    if isinstance(value, dict):
        return "`{" + ", ".join(f"{k}: {v}" for k, v in value.items()) + "}`"
    return f"`{value:g}`" if isinstance(value, float) else f"`{value}`"


def _allowed(check: Any) -> tuple[str, str]:
    """(allowed values, unit) of a check: the unit is taken out of a Real's description."""
    if isinstance(check, Real) and check.unit:
        return dataclasses.replace(check, unit="").describe(), check.unit
    return check.describe(), ""


def _row(key: str, check: Any, default: Any, meaning: str) -> list[str]:
    allowed, unit = _allowed(check)
    return [key, allowed, unit or "—", _value(default), meaning]


_HEADER = ["key", "allowed values", "unit", "default", "meaning"]


def scene_rows() -> dict[str, list[list[str]]]:
    """Every scene key as a row ``[key, allowed values, unit, default, meaning]``, by section.

    Raises
    ------
    KeyError
        If a key of the spec has no entry in :data:`ced.problem.scene.MEANINGS`: every key
        must have one line of meaning.
    """
    sections: dict[str, list[list[str]]] = {}
    sections["top"] = [
        _row("name", NAME_CHECK, "", MEANINGS["name"]),
        _row("mechanism.type", Choice(MECHANISM_TYPES), REQUIRED, MEANINGS["mechanism.type"]),
        ["effects", f"a list of distinct names from {', '.join(EFFECTS)}, or `auto`", "—",
         _value(DEFAULT_EFFECTS), MEANINGS["effects"]],
        ["gravity", "a list [gx, gy] of two finite numbers", "m/s^2", _value(DEFAULT_GRAVITY),
         MEANINGS["gravity"]],
        _row("tolerance", TOLERANCE_CHECK, DEFAULT_TOLERANCE, MEANINGS["tolerance"]),
        ["discretization", "a mapping (below) or `auto`", "—", "the block's defaults",
         MEANINGS["discretization"]],
        ["modal", "a mapping (below), or absent / `null`", "—", "none", MEANINGS["modal"]],
    ]
    for kind, fields in MECHANISM_FIELDS.items():
        sections[f"mechanism.{kind}"] = [
            _row(f"mechanism.{key}", check, default, MEANINGS[f"mechanism.{kind}.{key}"])
            for key, (check, default) in fields.items()]
    link_default = {"material": BUILTIN_LINK["material"], "section": BUILTIN_LINK["section"],
                    "flexible": BUILTIN_LINK["flexible"]}
    names = ", ".join(material_names())
    sections["links"] = [
        ["links.default", "a mapping of the keys below", "—", "the built-in link",
         MEANINGS["links.default"]],
        ["links.<link>.material", f"a library name ({names}) or an inline mapping", "—",
         _value(link_default["material"]), MEANINGS["links.<link>.material"]],
        ["links.<link>.section", "a mapping (below)", "—", _value(link_default["section"]),
         MEANINGS["links.<link>.section"]],
        ["links.<link>.flexible", "true or false", "—", _value(link_default["flexible"]),
         MEANINGS["links.<link>.flexible"]],
        _row("point_masses.<joint>", POINT_MASS_CHECK, None, MEANINGS["point_masses.<joint>"]),
    ]
    sections["material"] = [_row(f"material.{key}", check, default, meaning)
                            for key, (check, default, meaning) in MATERIAL_FIELDS.items()]
    sections["section"] = [_row(f"section.{key}", check, default, meaning)
                           for key, (check, default, meaning) in SECTION_FIELDS.items()]
    for block, fields in BLOCKS.items():
        sections[block] = [_row(f"{block}.{key}", check, default, MEANINGS[f"{block}.{key}"])
                           for key, (check, default) in fields.items()]
    return sections


def _topologies() -> str:
    lines = []
    for kind in MECHANISM_TYPES:
        if kind == "linkage":
            lines.append("- `linkage`: the links and joints its description names (input "
                         "link, dyads, points)")
            continue
        topo = topology(kind)
        lines.append(f"- `{kind}`: links {', '.join(topo.link_names)}; joints "
                     f"{', '.join(topo.joint_names)}")
    return "\n".join(lines)


def _used_by() -> str:
    lines = []
    for block, (selector, params) in MODEL_PARAMETERS.items():
        for choice, keys in params.items():
            used = ", ".join(f"`{block}.{k}`" for k in keys) or "no parameters"
            lines.append(f"- `{block}.{selector}: {choice}` uses {used}")
    return "\n".join(lines)


def scene_reference() -> str:
    """The scene reference page (Markdown): every key, allowed values, unit, default, meaning.

    Returns
    -------
    str
        The text of ``docs/reference/scene.md``, ending with a newline.
    """
    rows = scene_rows()
    aliases = ", ".join(f"{a} → {t}" for a, t in sorted(material_aliases().items()))
    parts = [
        "# Scene reference",
        "",
        "<!-- Generated by `make reference` from the scene spec "
        "in `ced/problem/scene.py` and `ced/problem/materials.py`; do not edit by hand "
        "(`tests/test_docs_reference.py` fails when this page is out of date). -->",
        "",
        "A scene is a YAML file (or a Python mapping) in SI units, angles in rad, speeds in "
        "rad/s. Every key is optional except `mechanism` and its lengths; a missing key takes "
        "its default. An unknown key, a value of the wrong type or out of range, or a linkage "
        "that cannot be assembled stops with a message naming the key path "
        "(`links.coupler.section.height: must be a finite number > 0 (m), got -1`) — exit "
        "code 2 from `ced run`, nothing written.",
        "",
        "Scalars follow YAML 1.2 (`1e-3` is a number, only `true`/`false` are booleans); an "
        "integer is accepted where a number is expected, NaN and infinities never.",
        "",
        "## Top level",
        "",
        markdown_table(_HEADER, rows["top"]),
        "",
        "## `mechanism`",
        "",
        "`mechanism.type` selects the keys that follow. Links and joints of each type (the "
        "names used under `links`, `point_masses` and in the dataset's `link` and `joint` "
        "dimensions):",
        "",
        _topologies(),
        "",
    ]
    for kind in MECHANISM_FIELDS:
        parts += [f"### `type: {kind}`", "", markdown_table(_HEADER, rows[f"mechanism.{kind}"]),
                  ""]
    parts += [
        "#### Dyads",
        "",
        "Each entry of `mechanism.dyads` has a `kind` and the keys of that kind "
        "(`links`, `joints` and `lengths` required); known points are the ground pivots, "
        "the input's tip, the far end of an RPR guide bar and the points of links placed "
        "before the dyad (guide: {doc}`../guide/six_bars`).",
        "",
        markdown_table(["kind", "key", "meaning"],
                       [[kind, key, DYAD_MEANINGS[f"{kind}.{key}"]]
                        for kind, keys in DYAD_KEYS.items() for key in keys]),
        "",
        "An RPR dyad: Whitworth's quick return as a crank shaper. The crank's tip B carries "
        "the block, which slides along the slotted lever turning about O; the lever's end C "
        "drives the ram through a rod (an RRP dyad). The lever is rigid; the crank and the "
        "rod may be flexible.",
        "",
        "```yaml",
        RPR_EXAMPLE.rstrip("\n"),
        "```",
        "",
    ]
    parts += [
        "## `links` and `point_masses`",
        "",
        "Each link starts from the built-in link, overridden key by key by `links.default`, "
        "then by the link's own entry (`links.crank`, …); `material` and `section` are "
        "replaced as a whole.",
        "",
        markdown_table(_HEADER, rows["links"]),
        "",
        "### Inline material",
        "",
        f"Library names are case-insensitive; aliases: {aliases or 'none'}.",
        "",
        markdown_table(_HEADER, rows["material"]),
        "",
        "### Section",
        "",
        "Shapes and their sizes: " + "; ".join(
            f"`{shape}` ({', '.join(keys)})" for shape, keys in SECTION_SHAPES.items()) + ".",
        "",
        markdown_table(_HEADER, rows["section"]),
        "",
    ]
    for block in BLOCKS:
        parts += [f"## `{block}`", "", _BLOCK_TITLES[block], "",
                  markdown_table(_HEADER, rows[block]), ""]
    parts += [
        "## Parameters of one choice",
        "",
        "A parameter used only by another choice of its block's selector must stay at its "
        "default (`damping: {model: modal, alpha: 0.1}` is an error):",
        "",
        _used_by(),
        "",
        "With `discretization.formulation: seed_lame` the default `time.integrator` is "
        "`houbolt`, the scheme the thesis recommends for its model.",
        "",
    ]
    return "\n".join(parts)
