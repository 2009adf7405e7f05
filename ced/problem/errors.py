"""Scene errors and the small value checks that raise them.

Shared by :mod:`ced.problem.scene`, :mod:`ced.problem.materials` and the study config
checks (:mod:`ced.study.config`). Every check takes the value and its dotted key path,
returns the normalized value (plain Python ``float``/``int``/``str``/``bool``) and raises
:class:`SceneError` naming the path and what is allowed.

Number rules (the choices of the scene format, docs/reference/scene.md):

- ``bool`` is never a number (``true`` is not 1).
- Where a float is expected an integer is accepted and converted to ``float``; ``-0.0``
  becomes ``0.0`` so that equal scenes have equal canonical JSON.
- Where an integer is expected a float with an integral value (``512.0``, ``1.0e+3``) is
  accepted and converted to ``int``; ``512.5`` is rejected.
- NaN and ±inf are always rejected; strings are never parsed as numbers.
"""
from __future__ import annotations

import math
import numbers
import re
import reprlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["SceneError", "Real", "Int", "AutoOr", "Choice", "Bool", "Text", "check_keys",
           "key_path", "join", "shown"]


class SceneError(ValueError):
    """An invalid scene.

    Parameters
    ----------
    path : str
        Dotted key path of the offending value, e.g. ``links.coupler.section.height`` or
        ``effects[2]``; ``<scene>`` for the document as a whole (YAML syntax, top-level type).
    message : str
        What is wrong and what is allowed.

    ``str(err)`` is ``f"{path}: {message}"``.
    """

    def __init__(self, path: str, message: str) -> None:
        super().__init__(f"{path}: {message}")
        self.path = path
        self.message = message

    def __reduce__(self):  # keep pickling (multiprocessing) working with two arguments
        return (type(self), (self.path, self.message))


def join(items) -> str:
    """``a, b, c`` for a message; non-strings are shown with ``repr``.

    Parameters
    ----------
    items : iterable
        Names or values.

    Returns
    -------
    str
        The items separated by commas.

    Examples
    --------
    >>> join(["a", 1, None])
    'a, 1, null'
    """
    return ", ".join(item if isinstance(item, str) else shown(item) for item in items)


#: Bounded repr: a value that YAML aliases expand to 10⁹ items is shown by its first few,
#: never built in full.
_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxdict, _REPR.maxlist, _REPR.maxtuple, _REPR.maxset = 3, 4, 6, 6, 6
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = 60, 60, 40


def shown(value: Any) -> str:
    """A short rendering of a user value for messages (at most 60 characters).

    Parameters
    ----------
    value : any
        The value to show.

    Returns
    -------
    str
        YAML-like spelling for null and booleans, a bounded ``repr`` otherwise.
    """
    if value is None or isinstance(value, bool):
        return {None: "null", True: "true", False: "false"}[value]
    text = _REPR.repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_number(value: Any) -> bool:
    # numpy.bool_ is not a numbers.Real, Python bool is: exclude it explicitly.
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _bound(value: float, open_: bool, sign: str) -> str:
    return f"{sign}{'' if open_ else '='} {value:g}"


@dataclass(frozen=True)
class Real:
    """A finite real number, optionally bounded (``low``/``high``, open or closed)."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    unit: str = ""

    def describe(self) -> str:
        bounds = []
        if self.low is not None:
            bounds.append(_bound(self.low, self.low_open, ">"))
        if self.high is not None:
            bounds.append(_bound(self.high, self.high_open, "<"))
        text = "a finite number" + (" " + " and ".join(bounds) if bounds else "")
        return text + (f" ({self.unit})" if self.unit else "")

    def __call__(self, value: Any, path: str) -> float:
        if not _is_number(value):
            raise SceneError(path, f"must be {self.describe()}, got {shown(value)}")
        try:
            x = float(value)
        except (OverflowError, ValueError, TypeError):
            x = math.inf
        if not math.isfinite(x):
            raise SceneError(path, f"must be {self.describe()}, got {shown(value)}")
        if (self.low is not None and (x < self.low or (self.low_open and x == self.low))) or (
            self.high is not None and (x > self.high or (self.high_open and x == self.high))
        ):
            raise SceneError(path, f"must be {self.describe()}, got {shown(value)}")
        return x + 0.0  # -0.0 -> 0.0


@dataclass(frozen=True)
class Int:
    """An integer in [``low``, ``high``], optionally odd or even."""

    low: int | None = None
    high: int | None = None
    odd: bool = False
    hint: str = ""
    even: bool = False

    def describe(self) -> str:
        text = "an odd integer" if self.odd else "an even integer" if self.even else "an integer"
        if self.low is not None and self.high is not None:
            text += f" from {self.low} to {self.high}"
        elif self.low is not None:
            text += f" >= {self.low}"
        elif self.high is not None:
            text += f" <= {self.high}"
        return text + (f" ({self.hint})" if self.hint else "")

    def __call__(self, value: Any, path: str) -> int:
        if isinstance(value, numbers.Integral) and not isinstance(value, bool):
            n = int(value)
        elif _is_number(value) and math.isfinite(float(value)) and float(value).is_integer():
            n = int(float(value))
        else:
            raise SceneError(path, f"must be {self.describe()}, got {shown(value)}")
        if (self.low is not None and n < self.low) or (self.high is not None and n > self.high) \
                or (self.odd and n % 2 == 0) or (self.even and n % 2):
            raise SceneError(path, f"must be {self.describe()}, got {shown(value)}")
        return n


@dataclass(frozen=True)
class AutoOr:
    """``auto`` (ced chooses) or a value that ``check`` accepts."""

    check: Any

    def describe(self) -> str:
        return f"auto or {self.check.describe()}"

    def __call__(self, value: Any, path: str) -> Any:
        if value == "auto":
            return "auto"
        try:
            return self.check(value, path)
        except SceneError:
            raise SceneError(path, f"must be {self.describe()}, got {shown(value)}") from None


@dataclass(frozen=True)
class Choice:
    """One of a fixed set of strings."""

    options: tuple[str, ...]

    def describe(self) -> str:
        return f"one of {join(self.options)}"

    def __call__(self, value: Any, path: str) -> str:
        if not isinstance(value, str) or value not in self.options:
            raise SceneError(path, f"unknown value {shown(value)}; allowed: {join(self.options)}")
        return value


@dataclass(frozen=True)
class Bool:
    """``true`` or ``false`` (no 0/1, no yes/no)."""

    def describe(self) -> str:
        return "true or false"

    def __call__(self, value: Any, path: str) -> bool:
        if not isinstance(value, bool):
            raise SceneError(path, f"must be true or false, got {shown(value)}")
        return bool(value)


@dataclass(frozen=True)
class Text:
    """A string (``nonempty`` to refuse ``""``)."""

    nonempty: bool = False

    def describe(self) -> str:
        return "a non-empty string" if self.nonempty else "a string"

    def __call__(self, value: Any, path: str) -> str:
        if not isinstance(value, str) or (self.nonempty and not value):
            raise SceneError(path, f"must be {self.describe()}, got {shown(value)}")
        return str(value)


def check_keys(value: Any, path: str, allowed, what: str = "key") -> Mapping:
    """Check that ``value`` is a mapping whose keys are all in ``allowed``; return it.

    The error for an unknown key is reported at ``path.key`` and lists the allowed keys.

    Parameters
    ----------
    value : any
        The value found at ``path``.
    path : str
        Dotted key path of ``value``.
    allowed : sequence of str
        Keys allowed there.
    what : str
        What a key is called in the message (``key``, ``link``, ``joint``).

    Returns
    -------
    mapping
        ``value``, unchanged.

    Raises
    ------
    SceneError
        If ``value`` is not a mapping, or at ``path.key`` for its first unknown key.
    """
    if not isinstance(value, Mapping):
        raise SceneError(path, f"must be a mapping with keys from: {join(allowed)}; "
                               f"got {shown(value)}")
    for key in value:
        if not isinstance(key, str) or key not in allowed:
            raise SceneError(key_path(path, key),
                             f"unknown {what} {shown(key)}; allowed: {join(allowed)}")
    return value


def key_path(path: str, key: Any) -> str:
    """``path.key``, or ``path[<repr>]`` for a key that is not a plain word (e.g. ``''``).

    Parameters
    ----------
    path : str
        Path of the mapping (``""`` at the top level).
    key : any
        The key.

    Returns
    -------
    str
        The dotted path of the key.

    Examples
    --------
    >>> key_path("links", "coupler"), key_path("", "time"), key_path("links", "")
    ('links.coupler', 'time', "links['']")
    """
    if isinstance(key, str) and re.fullmatch(r"\w+", key):
        return f"{path}.{key}" if path else key
    return f"{path}[{shown(key)}]"
