"""Reading and validating configuration files: the strict base model, the YAML loader, the messages.

Every configuration is a frozen pydantic model derived from :class:`StrictModel`. :func:`load_config`
reads a YAML file and returns the model or raises :class:`~excavsim.errors.ConfigError` whose
message names the file, the field, what was given and what is allowed, one line per problem.

The reader is defensive, since campaigns run unattended on files nobody looked at: a file is read
only if it is a regular file of at most :data:`MAX_FILE_BYTES`, as UTF-8 text (binary, UTF-16 or
UTF-32 files are named as such); the YAML may nest at most :data:`MAX_DEPTH` levels and expand, with
its aliases followed, to at most :data:`MAX_NODES` nodes (an alias bomb is refused from its node
graph, before anything is built); a mapping may not repeat a key; echoed values are cut to
:data:`~excavsim.errors.ECHO_CHARS` characters.
"""

from __future__ import annotations

import os
import pathlib
import re
import stat
import types
import typing
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from excavsim.errors import ConfigError, shorten

M = TypeVar("M", bound=BaseModel)

MAX_FILE_BYTES = 1 << 20  # the largest configuration file read [bytes]; the shipped ones are < 10 kB
MAX_DEPTH = 32  # deepest nesting of mappings and sequences, aliases followed; the shipped files nest <= 6
PATH_CHARS = 200  # longest path a message repeats (a goal given as a 1 MB string is taken for a path)
MAX_NODES = 20_000  # most YAML nodes, written or once every alias is expanded; the shipped files have < 100

_BOMS = ((b"\xff\xfe\x00\x00", "UTF-32"), (b"\x00\x00\xfe\xff", "UTF-32"), (b"\xff\xfe", "UTF-16"),
         (b"\xfe\xff", "UTF-16"))


class StrictModel(BaseModel):
    """Base for config sections: no unknown fields, no type coercion, no NaN or infinity, frozen."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


class _Loader(yaml.SafeLoader):
    """SafeLoader that reads YAML 1.2 floats such as ``5.0e5`` (PyYAML's 1.1 rules read a string), refuses
    a repeated mapping key, and refuses, while composing, nesting deeper than :data:`MAX_DEPTH` and more
    than :data:`MAX_NODES` nodes (PyYAML composes some 30 000 nodes a second: a large file fails fast)."""

    def __init__(self, stream: str):
        super().__init__(stream)
        self._depth = 0
        self._nodes = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        """Compose one node, refusing it beyond :data:`MAX_DEPTH` levels (PyYAML recurses once per level)
        or beyond :data:`MAX_NODES` nodes."""
        if self._depth >= MAX_DEPTH:
            raise yaml.composer.ComposerError(None, None, f"nested deeper than {MAX_DEPTH} levels (allowed: "
                                              f"at most {MAX_DEPTH})", self.peek_event().start_mark)
        self._nodes += 1
        if self._nodes > MAX_NODES:
            raise yaml.composer.ComposerError(None, None, f"more than {MAX_NODES} nodes (allowed: at most "
                                              f"{MAX_NODES})", self.peek_event().start_mark)
        self._depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        """Construct a mapping, refusing a key written twice (YAML forbids it; PyYAML keeps the last)."""
        if isinstance(node, yaml.MappingNode):
            first_line: dict[Any, int] = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    seen = key in first_line
                except TypeError:  # an unhashable key: the base class says so
                    continue
                if seen:
                    raise yaml.constructor.ConstructorError(
                        "while constructing a mapping", node.start_mark,
                        f"found the key {shorten(repr(key))} twice (first on line {first_line[key] + 1}); "
                        "allowed: each key once", key_node.start_mark)
                first_line[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
        |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
        |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


def _expanded_size(root: yaml.Node) -> tuple[int, int]:
    """(nodes, depth) of the YAML node graph ``root`` once every alias is expanded, without expanding it.

    Shared nodes (aliases) are counted once per use from a memo, so a 'billion laughs' file costs
    as little here as its text. Raises ValueError on a node that contains itself (a recursive alias).
    """
    memo: dict[int, tuple[int, int]] = {}
    active: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, children_done = stack.pop()
        key = id(node)
        if key in memo:
            continue
        if isinstance(node, yaml.ScalarNode):
            memo[key] = (1, 0)
            continue
        kids = [n for pair in node.value for n in pair] if isinstance(node, yaml.MappingNode) else list(node.value)
        if children_done:
            active.discard(key)
            size = 1 + sum(memo[id(k)][0] for k in kids)
            depth = 1 + max((memo[id(k)][1] for k in kids), default=0)
            memo[key] = (min(size, MAX_NODES + 1), depth)
            continue
        if key in active:
            raise ValueError("an alias refers to a node that contains it (a recursive structure); allowed: "
                             "aliases of finished nodes only")
        active.add(key)
        stack.append((node, True))
        for k in kids:
            if id(k) in active:
                raise ValueError("an alias refers to a node that contains it (a recursive structure); allowed: "
                                 "aliases of finished nodes only")
            if id(k) not in memo:
                stack.append((k, False))
    return memo[id(root)]


def read_text_file(path: str | os.PathLike, what: str, *, where: str | None = None) -> str:
    """The text of the file ``path`` (a configuration, a baseline): a regular file of at most
    :data:`MAX_FILE_BYTES`, in UTF-8.

    Args:
        path: the file.
        what: what the file holds, for messages (e.g. ``"RobotConfig"``, ``"baseline"``).
        where: how messages name the file (default: :func:`display_path` of ``path``).

    Raises:
        ConfigError: naming the file and why it cannot be read as text.
    """
    where = display_path(path) if where is None else where
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            kind = "a directory" if stat.S_ISDIR(info.st_mode) else "not a regular file"
            raise ConfigError(f"{where}: cannot read the {what} file: it is {kind}; allowed: a YAML file")
        if info.st_size > MAX_FILE_BYTES:
            raise ConfigError(f"{where}: the {what} file has {info.st_size} bytes (allowed: at most "
                              f"{MAX_FILE_BYTES} bytes)")
        with open(path, "rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"{where}: cannot read the {what} file ({exc.strerror or exc})") from None
    except ValueError as exc:  # e.g. an embedded NUL in the path
        raise ConfigError(f"{where}: cannot read the {what} file ({exc}); allowed: a path to a YAML file") from None
    if len(raw) > MAX_FILE_BYTES:
        raise ConfigError(f"{where}: the {what} file is larger than {MAX_FILE_BYTES} bytes (allowed: at most "
                          f"{MAX_FILE_BYTES} bytes)")
    for bom, name in _BOMS:
        if raw.startswith(bom):
            raise ConfigError(f"{where}: the {what} file is {name} text; allowed: UTF-8 (save it as UTF-8)")
    if raw[1::2].count(0) > len(raw) // 4 or raw[0::2].count(0) > len(raw) // 4:
        raise ConfigError(f"{where}: the {what} file looks like UTF-16 text without a byte-order mark; allowed: "
                          "UTF-8 (save it as UTF-8)")
    if b"\x00" in raw:
        raise ConfigError(f"{where}: the {what} file is binary (it holds NUL bytes at offset {raw.index(0)}); "
                          "allowed: YAML text in UTF-8")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{where}: the {what} file is not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset "
                          f"{exc.start}); allowed: UTF-8 (save it as UTF-8)") from None


def parse_yaml(text: str, *, source: str) -> Any:
    """Parse YAML ``text`` within the loader's limits (depth, expanded size, unique keys).

    Args:
        text: the document.
        source: where it came from, for messages.

    Raises:
        ConfigError: naming ``source`` and what is wrong with the document.
    """
    try:
        loader = _Loader(text)
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            size, depth = _expanded_size(node)
            if size > MAX_NODES:
                raise ConfigError(f"{source}: the YAML expands to more than {MAX_NODES} nodes with its aliases "
                                  f"followed (allowed: at most {MAX_NODES}; an alias bomb?)")
            if depth > MAX_DEPTH:
                raise ConfigError(f"{source}: the YAML nests {depth} levels with its aliases followed (allowed: at "
                                  f"most {MAX_DEPTH})")
            return loader.construct_document(node)
        finally:
            loader.dispose()
    except yaml.YAMLError as exc:
        raise ConfigError(f"{source}: not valid YAML: {shorten(exc, 400)}") from None
    except (ValueError, TypeError, OverflowError, RecursionError, MemoryError) as exc:
        # e.g. an integer of more than 4300 digits, a timestamp with month 13
        raise ConfigError(f"{source}: not valid YAML: {shorten(exc, 200)}") from None


def _fields_at(model: type[BaseModel], loc: tuple) -> list[str] | None:
    """The field names of the section of ``model`` at ``loc`` (a validation error's location without its last
    part), following nested models, lists and mappings of models; None where the section is no model."""
    current: Any = model
    skip = 0  # location parts that are a list's index or a mapping's key
    for part in loc:
        if skip:
            skip -= 1
            continue
        if not (isinstance(current, type) and issubclass(current, BaseModel)) or part not in current.model_fields:
            return None
        current = current.model_fields[part].annotation
        for _ in range(4):  # unwrap Optional, list[...] and dict[str, ...] around a model
            if isinstance(current, type) and issubclass(current, BaseModel):
                break
            args = [a for a in typing.get_args(current) if a is not type(None)]
            if not args:
                return None
            if typing.get_origin(current) in (list, dict):
                skip += 1
            current = args[-1]
    if skip or not (isinstance(current, type) and issubclass(current, BaseModel)):
        return None
    return list(current.model_fields)


def _field_loc(model: type[BaseModel], loc: tuple) -> tuple:
    """A validation error's location without the tags pydantic inserts after a field whose type is a union
    (``seeds.int``, ``seeds.list[int]``: both are ``seeds``)."""
    out: list = []
    current: Any = model
    tag_next = False
    for part in loc:
        if tag_next and isinstance(part, str):
            tag_next = False
            continue
        tag_next = False
        out.append(part)
        if not (isinstance(current, type) and issubclass(current, BaseModel)) or part not in current.model_fields:
            current = None
            continue
        annotation = current.model_fields[part].annotation
        members = [a for a in typing.get_args(annotation) if a is not type(None)]
        tag_next = typing.get_origin(annotation) in (typing.Union, types.UnionType) and len(members) > 1
        current = annotation
    return tuple(out)


def _describe_error(err: dict[str, Any], model: type[BaseModel] | None = None) -> str:
    """One line of a validation message: the field, what is wrong, what is allowed, what was given (cut short)."""
    loc = shorten(".".join(str(p) for p in err["loc"]) or "(top level)")
    kind = err["type"]
    given = shorten(repr(err.get("input")))
    if kind == "missing":
        return f"{loc}: required field is missing"
    if kind == "extra_forbidden":
        fields = _fields_at(model, tuple(err["loc"][:-1])) if model is not None else None
        allowed = f"; allowed: {shorten(', '.join(fields), 300)}" if fields else ""
        return f"{loc}: unknown field (given {given}); check the spelling against the documented fields{allowed}"
    msg = shorten(err["msg"].removeprefix("Value error, "), 400)
    ctx = err.get("ctx") or {}
    if kind == "finite_number":
        msg = "must be a finite number"
    elif "gt" in ctx or "ge" in ctx or "lt" in ctx or "le" in ctx:
        lo = f"> {ctx['gt']}" if "gt" in ctx else (f">= {ctx['ge']}" if "ge" in ctx else "")
        hi = f"< {ctx['lt']}" if "lt" in ctx else (f"<= {ctx['le']}" if "le" in ctx else "")
        msg = f"{msg} (allowed: {' and '.join(p for p in (lo, hi) if p)})"
    if not err["loc"] and kind == "value_error":  # a check of the whole section: its message names the fields
        return f"{loc}: {msg}"
    return f"{loc}: {msg}; given {given}"


def parse_config(data: Any, model: type[M], *, source: str) -> M:
    """Validate already-parsed data against a config model.

    Args:
        data: the parsed YAML document.
        model: the pydantic config class.
        source: where the data came from, for messages (a file path).

    Raises:
        ConfigError: naming ``source``, each offending field, the given value and what is allowed.
    """
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: the top level must be a mapping of fields, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        groups: dict[tuple, list[dict[str, Any]]] = {}  # a union's members' errors on one line
        for e in exc.errors(include_url=False):
            e["loc"] = _field_loc(model, tuple(e["loc"]))
            groups.setdefault(e["loc"], []).append(e)
        lines = []
        for errs in groups.values():
            if len(errs) > 1 and all(e["type"] not in ("missing", "extra_forbidden") for e in errs):
                msgs = [errs[0]["msg"]] + [e["msg"].removeprefix("Input should be ") for e in errs[1:]]
                errs = [{**errs[0], "msg": " or ".join(dict.fromkeys(msgs)), "ctx": None, "type": "union"}]
            lines.extend(_describe_error(e, model) for e in errs)
        raise ConfigError(f"{source}: invalid {model.__name__}:\n  " + "\n  ".join(lines)) from None
    except ConfigError as exc:  # raised by a check inside a model (e.g. an unknown soil name)
        text = "\n".join(shorten(line, 400) for line in str(exc).splitlines())
        raise ConfigError(f"{source}: invalid {model.__name__}: {text}") from None
    except (TypeError, ArithmeticError, RecursionError, MemoryError) as exc:
        raise ConfigError(f"{source}: invalid {model.__name__}: {shorten(exc, 200)}") from None


def display_path(path: str | os.PathLike) -> str:
    """A path as messages show it: control characters escaped, cut to :data:`PATH_CHARS` characters."""
    text = os.fspath(path)
    return shorten("".join(c if c.isprintable() else repr(c)[1:-1] for c in text[:PATH_CHARS]) + text[PATH_CHARS:],
                   PATH_CHARS)


def load_config(path: str | pathlib.Path, model: type[M]) -> M:
    """Read and validate a YAML configuration file.

    Args:
        path: the YAML file.
        model: the pydantic config class, e.g. :class:`RobotConfig`.

    Returns:
        The validated, frozen configuration.

    Raises:
        ConfigError: the file is missing, unreadable, too large, not UTF-8, not YAML within the
            loader's limits, or a field is invalid.
    """
    path = pathlib.Path(path)
    where = display_path(path)
    data = parse_yaml(read_text_file(path, model.__name__, where=where), source=where)
    return parse_config(data, model, source=where)
