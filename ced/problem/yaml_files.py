"""The one YAML reader of scenes and study configs, with the same limits for both.

A document is read through :func:`load_yaml` with

- at most :data:`MAX_FILE_BYTES` read from the file (so ``/dev/zero`` or a multi-gigabyte
  file is refused at once, not read forever);
- duplicate keys in a mapping refused (YAML says keys are unique; PyYAML keeps the last);
- nesting deeper than :data:`MAX_DEPTH` and documents that expand, through aliases, to more
  than :data:`MAX_NODES` values refused ("billion laughs": a few lines of anchors that expand
  to 10⁹ values) — :func:`check_structure`, which also guards a mapping handed to ced
  directly;
- one of two dialects: ``"1.2"`` for scenes (YAML 1.2 core schema numbers and booleans:
  ``1e-3`` is a float, ``yes`` a string) and ``"1.1"`` for study configs, which Snakemake
  reads with PyYAML's YAML 1.1 rules (there ``1e-3`` is a string: ced reads them the same way
  so that ``ced check`` sees what the pipeline will see).

Every refusal is a :class:`~ced.problem.errors.SceneError` at ``<scene>`` or ``<config>``.
"""
from __future__ import annotations

import io
import os
import re
from pathlib import Path
from typing import Any

import yaml

from .errors import SceneError

__all__ = ["load_yaml", "check_structure", "MAX_FILE_BYTES", "MAX_DEPTH", "MAX_NODES"]

#: Largest file read, bytes (a scene is about 1 kB, the default study config 3 kB).
MAX_FILE_BYTES = 1_000_000
#: Deepest nesting of mappings and lists (a scene nests 4 levels, a study config 6).
MAX_DEPTH = 32
#: Most values (mapping entries, list items, scalars) once aliases are expanded.
MAX_NODES = 100_000


class _UniqueKeys(yaml.SafeLoader):
    """SafeLoader that refuses duplicate keys in a mapping."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = set()
            for key_node, _ in node.value:
                if isinstance(key_node, yaml.ScalarNode) and key_node.tag != "tag:yaml.org,2002:merge":
                    key = (key_node.tag, key_node.value)
                    if key in seen:
                        raise yaml.constructor.ConstructorError(
                            "while constructing a mapping", node.start_mark,
                            f"found duplicate key {key_node.value!r}", key_node.start_mark)
                    seen.add(key)
        return super().construct_mapping(node, deep=deep)


class _Yaml11(_UniqueKeys):
    """YAML 1.1 as PyYAML (and so Snakemake) reads it, with unique keys."""


class _Yaml12(_UniqueKeys):
    """YAML 1.2 core-schema scalars: numbers and booleans as YAML 1.2 defines them."""


_BOOL, _INT, _FLOAT = (f"tag:yaml.org,2002:{t}" for t in ("bool", "int", "float"))
_Yaml12.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers if tag not in (_BOOL, _INT, _FLOAT)]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Yaml12.add_implicit_resolver(
    _BOOL, re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF"))
_Yaml12.add_implicit_resolver(
    _INT, re.compile(r"^[-+]?(?:0|[1-9][0-9]*)$"), list("-+0123456789"))
_Yaml12.add_implicit_resolver(
    _FLOAT,
    re.compile(r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
               r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"),
    list("-+0123456789."))

_LOADERS = {"1.1": _Yaml11, "1.2": _Yaml12}


def check_structure(value: Any, where: str) -> None:
    """Refuse a document nested deeper than :data:`MAX_DEPTH` or larger than
    :data:`MAX_NODES` values once shared parts (YAML aliases) are counted each time they
    appear. Iterative: no recursion, and it stops at the first value over the limit.

    Parameters
    ----------
    value : any
        A parsed document (dicts, lists, scalars).
    where : str
        The key path of errors (``<scene>`` or ``<config>``).

    Raises
    ------
    SceneError
        At ``where``, if the document is too deep or too large.
    """
    stack = [(value, 1)]
    count = 0
    while stack:
        item, depth = stack.pop()
        count += 1
        if count > MAX_NODES:
            raise SceneError(where, f"too large: more than {MAX_NODES} values once YAML "
                                    "aliases are expanded (an alias bomb?)")
        if isinstance(item, dict):
            children = [*item.keys(), *item.values()]
        elif isinstance(item, (list, tuple)):
            children = list(item)
        else:
            continue
        if depth >= MAX_DEPTH and children:
            raise SceneError(where, f"nested more than {MAX_DEPTH} levels deep")
        stack.extend((child, depth + 1) for child in children)


def _read_bounded(path: Path, where: str, hint: str) -> str:
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise SceneError(where, f"cannot read {str(path)[:200]!r}: {exc}{hint}") from None
    if len(data) > MAX_FILE_BYTES:
        raise SceneError(where, f"{str(path)[:200]!r} is larger than {MAX_FILE_BYTES} bytes: "
                                f"not a {where.strip('<>')} file{hint}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(where, f"cannot read {str(path)[:200]!r}: not UTF-8 text ({exc})"
                                f"{hint}") from None


def load_yaml(path: str | os.PathLike, where: str = "<scene>", dialect: str = "1.2",
              hint: str = "") -> Any:
    """Read and parse one YAML file within the limits of this module.

    Parameters
    ----------
    path : path of the file
    where : the key path errors are reported at (``<scene>`` or ``<config>``)
    dialect : ``"1.2"`` (scenes) or ``"1.1"`` (study configs, as Snakemake reads them)
    hint : appended to read errors (what to pass instead)

    Returns
    -------
    The document: plain dicts, lists and scalars.
    """
    text = _read_bounded(Path(path), where, hint)
    if "\x00" in text:
        raise SceneError(where, f"{str(path)[:200]!r} contains NUL bytes: not a YAML file{hint}")
    stream = io.StringIO(text)
    stream.name = str(path)  # PyYAML puts the stream's name into its error marks
    try:
        value = yaml.load(stream, Loader=_LOADERS[dialect])  # noqa: S506 - SafeLoader subclass
    except yaml.YAMLError as exc:
        raise SceneError(where, f"invalid YAML: {exc}") from None
    except RecursionError:
        raise SceneError(where, f"nested more than {MAX_DEPTH} levels deep") from None
    check_structure(value, where)
    return value
