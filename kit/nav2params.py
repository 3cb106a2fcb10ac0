"""Nav2 parameter files read as ROS 2 reads them, and an account of every key.

A Nav2 parameter file is YAML whose keys name nodes down to a ``ros__parameters`` mapping::

    amcl:                          # the node /amcl
      ros__parameters: {...}
    local_costmap:
      local_costmap:               # the node /local_costmap/local_costmap
        ros__parameters: {...}
    /**:                           # every node (ROS 2's wildcards: * one name, ** any)
      ros__parameters: {use_sim_time: true}
    robot1:                        # the node /robot1/amcl (a namespace)
      amcl:
        ros__parameters: {...}

A node's key may also be a path (``/robot1/amcl``). :class:`Nav2File` reads such a file
(YAML anchors and merge keys resolved, duplicate keys noted), finds each node's parameters as
ROS 2 applies them — every entry whose name matches the node, wildcards included, in file
order, the later winning — and flattens nested mappings into ROS 2's dotted names
(``FollowPath: {BaseObstacle.scale: 0.02}`` is ``FollowPath.BaseObstacle.scale``).
``<robot_namespace>`` (Nav2's placeholder for the launch file's namespace) is replaced by the
namespace, or removed.

:class:`ParameterReport` is the account: each key of the file is either **used** (with what
it set), or **not used** with the reason, named once; the kit's own values that the file does
not set but that make the kit behave otherwise than Nav2 with that file would are listed as
**kept**. :class:`Section` is how loaders read a node: typed getters that record each key they
use, accept a number or a boolean given as a string (and say so), and collect errors instead
of stopping at the first.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

__all__ = ["Nav2File", "ParameterReport", "Section", "flatten"]

T = TypeVar("T")

PLACEHOLDER = "<robot_namespace>"


def flatten(params: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """ROS 2's parameter names of a nested mapping: ``{"a": {"b": 1}}`` → ``{"a.b": 1}``.
    Lists and scalars are values; an empty mapping is a value (``{}``)."""
    out: dict[str, Any] = {}
    for key, value in params.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping) and value:
            out.update(flatten(value, name + "."))
        else:
            out[name] = value
    return out


def _tokens(key: Any) -> list[str]:
    return [t for t in str(key).strip().split("/") if t]


@dataclass
class _Entry:
    """One ``ros__parameters`` mapping of the file: the node name pattern (tokens) and its
    parameters, flattened."""

    pattern: tuple[str, ...]
    params: dict[str, Any]

    @property
    def name(self) -> str:
        return "/".join(self.pattern)


def _matches(pattern: Sequence[str], name: Sequence[str], namespace: Sequence[str]) -> bool:
    """ROS 2's node-name wildcards: ``*`` one token, ``**`` any number (none too);
    ``<robot_namespace>`` stands for the namespace's tokens."""
    expanded: list[str] = []
    for token in pattern:
        if token == PLACEHOLDER:
            expanded.extend(namespace)
        else:
            expanded.append(token)

    def match(i: int, j: int) -> bool:
        if i == len(expanded):
            return j == len(name)
        token = expanded[i]
        if token == "**":
            return any(match(i + 1, k) for k in range(j, len(name) + 1))
        if j == len(name):
            return False
        return (token == "*" or token == name[j]) and match(i + 1, j + 1)

    return match(0, 0)


class Nav2File:
    """A Nav2 parameter file (or an already parsed mapping) as ROS 2 reads it.

    Parameters
    ----------
    source
        A path, or the parsed YAML (a mapping of node names).
    namespace
        The robot's namespace (``"robot1"``) when the file configures several; found by
        itself when the file has one.

    Raises
    ------
    ValueError
        No such file, not YAML, not a mapping of nodes, no ``ros__parameters`` anywhere, or a
        node configured under several namespaces and no ``namespace`` given.
    """

    def __init__(self, source: str | Path | Mapping[str, Any], namespace: str | None = None
                 ) -> None:
        self.notes: list[str] = []
        if isinstance(source, Mapping):
            self.origin = "parameters"
            data: Any = source
        else:
            self.origin = str(source)
            data = self._read(Path(source))
        if not isinstance(data, Mapping):
            raise ValueError(f"{self.origin}: a Nav2 parameter file is a YAML mapping of node "
                             f"names; got {type(data).__name__}")
        self.entries: list[_Entry] = []
        self.stray: dict[str, Any] = {}
        """Keys that lead to no ``ros__parameters`` (not read by ROS 2), flattened."""
        self._walk(data, [])
        if not self.entries:
            raise ValueError(f"{self.origin}: no node with ros__parameters in it (top-level "
                             f"keys: {', '.join(map(str, data)) or 'none'})")
        self.namespace = _tokens(namespace) if namespace else None
        for entry in self.entries:
            for key, value in entry.params.items():
                if isinstance(value, str) and PLACEHOLDER in value:
                    ns = "/" + "/".join(self.namespace) if self.namespace else ""
                    entry.params[key] = value.replace(PLACEHOLDER, ns)
                    self.notes.append(f"{entry.name}.{key}: {PLACEHOLDER} read as "
                                      f"{ns or 'no namespace'!r}")

    def _read(self, path: Path) -> Any:
        from ruamel.yaml import YAML
        from ruamel.yaml.constructor import DuplicateKeyError
        from ruamel.yaml.error import YAMLError

        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise ValueError(f"{path}: no such parameter file") from None
        except IsADirectoryError:
            raise ValueError(f"{path}: a directory, not a parameter file") from None
        except UnicodeDecodeError as exc:
            raise ValueError(f"{path}: not a text file ({exc.reason})") from None
        try:
            return YAML(typ="safe", pure=True).load(text)
        except DuplicateKeyError as exc:
            yaml = YAML(typ="safe", pure=True)
            yaml.allow_duplicate_keys = True
            first = str(exc).splitlines()
            self.notes.append(f"{path.name}: a key appears twice ({' '.join(first[:3])}); "
                              f"the kit reads the first")
            return yaml.load(text)
        except YAMLError as exc:
            raise ValueError(f"{path}: not valid YAML ({' '.join(str(exc).split())})") from None

    def _walk(self, node: Any, path: list[str]) -> None:
        if not isinstance(node, Mapping):
            if path:
                self.stray["/".join(path)] = node
            return
        for key, value in node.items():
            if key == "ros__parameters":
                if not path:
                    self.stray["ros__parameters"] = value
                    continue
                if value is None:
                    value = {}
                if not isinstance(value, Mapping):
                    raise ValueError(f"{self.origin}: {'/'.join(path)}.ros__parameters must be "
                                     f"a mapping of parameters; got {value!r}")
                self.entries.append(_Entry(tuple(path), flatten(
                    {str(k): v for k, v in value.items()})))
            else:
                self._walk(value, [*path, *_tokens(key)])

    # ------------------------------------------------------------------ finding nodes
    def _concrete(self, entry: _Entry) -> bool:
        return not any(t in ("*", "**", PLACEHOLDER) for t in entry.pattern)

    def namespaces(self, name: str) -> list[tuple[str, ...]]:
        """The namespaces under which the file names the node ``name`` (``"amcl"``,
        ``"local_costmap/local_costmap"``) outright, in file order."""
        want = tuple(_tokens(name))
        found: list[tuple[str, ...]] = []
        for entry in self.entries:
            p = tuple(t for t in entry.pattern if t != PLACEHOLDER)
            if len(p) >= len(want) and p[len(p) - len(want):] == want and \
                    not any(t in ("*", "**") for t in p):
                ns = p[:len(p) - len(want)]
                if ns not in found:
                    found.append(ns)
        return found

    def misnested_costmap(self, name: str) -> str | None:
        """What is wrong when the file configures a costmap (``"global_costmap"``,
        ``"local_costmap"``) one level too high: Nav2's costmap node is
        ``/global_costmap/global_costmap``, so ``global_costmap: ros__parameters: …``
        configures a node ``/global_costmap`` that Nav2 does not have, and Nav2 runs the
        costmap with its defaults. ``None`` when the file does not."""
        for ns in self.namespaces(name):
            if not ns or ns[-1] != name:
                where = "/" + "/".join((*ns, name))
                return (f"{self.origin}: the parameters under {where} configure a node "
                        f"{where}, which Nav2 does not have: its costmap node is "
                        f"{where}/{name}, so Nav2 would run the costmap with its defaults; "
                        f"nest them one level deeper ({name}: {name}: ros__parameters: ...)")
        return None

    def node(self, name: str, *alternatives: str) -> tuple[str, dict[str, Any],
                                                           dict[str, str]]:
        """The parameters of node ``name`` (or the first of ``alternatives`` the file names):
        ``(the node's name, flat parameters, the name of the entry each came from)``; no
        parameters when the file does not configure it.

        Raises ``ValueError`` when the file names the node under several namespaces and no
        ``namespace`` was given."""
        for candidate in (name, *alternatives):
            spaces = self.namespaces(candidate)
            if spaces:
                break
        else:
            candidate, spaces = name, []
        if self.namespace is not None:
            ns = tuple(self.namespace)
        elif len(spaces) > 1:
            listed = ", ".join("/" + "/".join(s) if s else "(none)" for s in spaces)
            raise ValueError(f"{self.origin}: {candidate} is configured under several "
                             f"namespaces ({listed}): name the robot's namespace")
        else:
            ns = spaces[0] if spaces else ()
        full = (*ns, *_tokens(candidate))
        params: dict[str, Any] = {}
        origin: dict[str, str] = {}
        for entry in self.entries:
            if _matches(entry.pattern, full, ns):
                params.update(entry.params)
                origin.update(dict.fromkeys(entry.params, entry.name))
        return candidate, params, origin

    def keys(self) -> list[str]:
        """Every key of the file as a report names it (``"amcl:alpha1"``,
        ``"local_costmap/local_costmap:voxel_layer.enabled"``), in file order."""
        return [f"{entry.name}:{key}" for entry in self.entries for key in entry.params] + \
            [f"{path}:" if path else ":" for path in self.stray]

    def report(self) -> ParameterReport:
        """A report listing every key of the file, the keys outside any ``ros__parameters``
        already reported (ROS 2 does not read them), with the file's notes."""
        report = ParameterReport(self.origin, self.keys(), notes=list(self.notes))
        for path in self.stray:
            report.ignore(f"{path}:" if path else ":",
                          "not under ros__parameters: ROS 2 does not read it")
        return report


# ---------------------------------------------------------------------- the account

@dataclass
class ParameterReport:
    """What became of each key of a parameter file.

    ``used`` maps a key (``"controller_server.FollowPath.max_vel_x"``) to what it set;
    ``ignored`` maps a key to why it is not used; ``kept`` maps a kit parameter the file does
    not set to its value and why it matters; ``notes`` are other things worth knowing (a
    number given as a string, a footprint smaller than the robot). ``keys`` lists every key
    of the file, in file order."""

    origin: str = "parameters"
    keys: list[str] = field(default_factory=list)
    used: dict[str, str] = field(default_factory=dict)
    ignored: dict[str, str] = field(default_factory=dict)
    kept: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)

    def use(self, key: str, what: str = "") -> None:
        self.ignored.pop(key, None)
        self.used[key] = what

    def ignore(self, key: str, reason: str) -> None:
        """``key`` is not used, for ``reason`` (the first reason given stays)."""
        if key not in self.used and key not in self.ignored:
            self.ignored[key] = reason

    def unuse(self, key: str, reason: str) -> None:
        """A key a loader read but then did not use after all (``reason``; nothing when the
        file does not have the key)."""
        if key in self.used or key in self.keys:
            self.used.pop(key, None)
            if reason:
                self.ignored[key] = reason

    def keep(self, name: str, message: str) -> None:
        self.kept[name] = message

    def note(self, message: str) -> None:
        if message not in self.notes:
            self.notes.append(message)

    def unaccounted(self) -> list[str]:
        """Keys of the file neither used nor reported (none, once a loader is done)."""
        return [k for k in self.keys if k not in self.used and k not in self.ignored]

    def raise_errors(self) -> None:
        """One ``ValueError`` naming every value that could not be read."""
        if self.errors:
            raise ValueError(f"{self.origin}: " + "; ".join(self.errors))

    def summary(self) -> str:
        return (f"{len(self.used)} keys used, {len(self.ignored)} not used, "
                f"{len(self.kept)} kit values kept")

    def unused_groups(self) -> dict[tuple[str, str], list[str]]:
        """The keys not used, grouped by ``(node, reason)`` in file order: each once."""
        groups: dict[tuple[str, str], list[str]] = {}
        order = [k for k in self.keys if k in self.ignored] + \
            [k for k in self.ignored if k not in set(self.keys)]
        for key in order:
            node = key.partition(":")[0]
            groups.setdefault((node, self.ignored[key]), []).append(key)
        return groups

    def lines(self, width: int = 100) -> list[str]:
        """The report as text: a summary line, the unused keys grouped by node and reason
        (each key named once), the kit values kept, the notes."""
        out = [f"Nav2 parameters from {self.origin}: {self.summary()}"]
        groups = self.unused_groups()
        if groups:
            out.append("not used:")
        for (node, reason), keys in groups.items():
            names = [k.partition(":")[2] or k for k in keys]
            out.extend(_wrap(f"  {node} — {reason}: ", ", ".join(names), width))
        if self.kept:
            out.append("kit values kept (the file does not set them):")
            for name, message in self.kept.items():
                out.extend(_wrap("  ", f"{name}: {message}", width))
        if self.notes:
            out.append("notes:")
            for message in self.notes:
                out.extend(_wrap("  ", message, width))
        return out


def _wrap(head: str, text: str, width: int) -> list[str]:
    import textwrap

    return textwrap.wrap(text, width=width, initial_indent=head, subsequent_indent=" " * 6,
                         break_on_hyphens=False, break_long_words=False) or [head]


# ---------------------------------------------------------------------- typed reading

_TRUE = {"true", "yes", "on"}
_FALSE = {"false", "no", "off"}
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*([eE][+-]?\d+)?|\.\d+([eE][+-]?\d+)?|\.?inf|nan)$",
                     re.IGNORECASE)
MISSING: Any = object()


class Section:
    """A node's (or a plugin's) parameters, read through typed getters that account for each
    key in a :class:`ParameterReport`.

    Parameters
    ----------
    report
        Where uses, reasons and errors go.
    node
        The node's name as the report shows it (``"controller_server"``).
    params
        The node's parameters, flat (``{"FollowPath.max_vel_x": 0.26, ...}``).
    prefix
        The plugin's name within the node (``"FollowPath"``): the getters take names relative
        to it.
    """

    def __init__(self, report: ParameterReport, node: str, params: Mapping[str, Any],
                 prefix: str = "", origin: Mapping[str, str] | None = None) -> None:
        self.report, self.node, self.params = report, node, params
        self.origin = origin or {}
        self.prefix = f"{prefix}." if prefix and not prefix.endswith(".") else prefix

    def key(self, name: str) -> str:
        """The report's name of parameter ``name``: ``entry:prefix.name``, the entry being
        the file's node name that set it (a wildcard's, ``**``, or the node's)."""
        full = self.prefix + name
        return f"{self.origin.get(full, self.node)}:{full}"

    def sub(self, prefix: str) -> Section:
        """The section of a plugin (or an observation source) within this one."""
        return Section(self.report, self.node, self.params, self.prefix + prefix + ".",
                       self.origin)

    def has(self, name: str) -> bool:
        return self.prefix + name in self.params

    def names(self) -> list[str]:
        """The parameters under this section's prefix, relative to it."""
        n = len(self.prefix)
        return [k[n:] for k in self.params if k.startswith(self.prefix)]

    def raw(self, name: str, default: Any = MISSING) -> Any:
        return self.params.get(self.prefix + name, default)

    def use(self, name: str, what: str = "") -> None:
        if self.has(name):
            self.report.use(self.key(name), what)

    def ignore(self, name: str, reason: str) -> None:
        if self.has(name):
            self.report.ignore(self.key(name), reason)

    def ignore_all(self, reason: str, names: Iterable[str] | None = None) -> None:
        """Every parameter of the section (or of ``names`` that the file has) not used yet
        is not used, for ``reason``."""
        for name in (self.names() if names is None else names):
            if self.has(name):
                self.report.ignore(self.key(name), reason)

    def _error(self, name: str, expected: str, value: Any) -> None:
        hint = ""
        if isinstance(value, str) and ("$(" in value or "${" in value):
            hint = " (a launch-file substitution left in the file?)"
        self.report.errors.append(f"{self.key(name).replace(':', '.')} must be {expected}; got "
                                  f"{value!r}{hint}")

    def _string_note(self, name: str, value: str, read: Any) -> None:
        self.report.note(f"{self.key(name).replace(':', '.')} is given as the string "
                         f"{value!r}: read as {read!r}")

    def get(self, name: str, default: T, what: str = "") -> T:
        """The parameter ``name`` of ``default``'s type (bool, int, float, str), or
        ``default`` when the file does not set it. A value of another type that reads as the
        right one (``"0.5"``, ``"true"``, ``3`` for a float, ``3.0`` for an int) is taken and
        noted; anything else is an error (collected: see
        :meth:`ParameterReport.raise_errors`) and gives ``default``."""
        if not self.has(name):
            return default
        value = self.raw(name)
        kind = type(default)
        read = _convert(value, kind)
        if read is MISSING:
            self._error(name, _EXPECTED.get(kind, kind.__name__), value)
            return default
        if isinstance(value, str) and kind is not str:
            self._string_note(name, value, read)
        elif kind is int and isinstance(value, float):
            self.report.note(f"{self.key(name).replace(':', '.')} is an integer parameter "
                             f"given as {value!r}: read as {read}")
        self.report.use(self.key(name), what or f"{read!r}")
        return read

    def get_list(self, name: str, default: list[str], what: str = "") -> list[str]:
        """A list of names: a YAML list, or a string of names (``"scan"``,
        ``"scan bump"``, ``"[a, b]"``), as Nav2 reads ``observation_sources`` and
        ``plugins``."""
        if not self.has(name):
            return list(default)
        value = self.raw(name)
        if isinstance(value, str):
            text = value.strip()
            if text.startswith("[") and text.endswith("]"):
                text = text[1:-1].replace(",", " ")
            names = [t.strip("'\" ") for t in text.split() if t.strip("'\" ")]
        elif isinstance(value, list) and all(isinstance(v, (str, int, float)) for v in value):
            names = [str(v) for v in value]
        elif value is None:
            names = []
        else:
            self._error(name, "a list of names", value)
            return list(default)
        self.report.use(self.key(name), what or ", ".join(names) or "none")
        return names


_EXPECTED = {bool: "true or false", int: "an integer", float: "a number", str: "a string"}


def _convert(value: Any, kind: type) -> Any:
    """``value`` as ``kind``, or ``MISSING`` when it does not read as one."""
    if kind is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.strip().lower() in _TRUE | _FALSE:
            return value.strip().lower() in _TRUE
        return MISSING
    if kind in (int, float):
        if isinstance(value, bool):
            return MISSING
        if isinstance(value, str):
            text = value.strip()
            if not _NUMBER.match(text):
                return MISSING
            value = float(text)
        if not isinstance(value, (int, float)):
            return MISSING
        if kind is int:
            if isinstance(value, float) and not (math.isfinite(value) and value.is_integer()):
                return MISSING
            return int(value)
        return float(value)
    if kind is str:
        if isinstance(value, str):
            return value
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return str(value)
        return MISSING
    return value if isinstance(value, kind) else MISSING
