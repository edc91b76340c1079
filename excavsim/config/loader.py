"""Reading and validating configuration files: the strict base model, the YAML loader, the messages.

Every configuration is a frozen pydantic model derived from :class:`StrictModel`. :func:`load_config`
reads a YAML file and returns the model or raises :class:`~excavsim.errors.ConfigError` whose
message names the file, the field, what was given and what is allowed, one line per problem.
"""

from __future__ import annotations

import pathlib
import re
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from excavsim.errors import ConfigError

M = TypeVar("M", bound=BaseModel)


class StrictModel(BaseModel):
    """Base for config sections: no unknown fields, no type coercion, no NaN or infinity, frozen."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads YAML 1.2 floats such as ``5.0e5`` (PyYAML's 1.1 rules read a string)."""

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


def _describe_error(err: dict[str, Any]) -> str:
    loc = ".".join(str(p) for p in err["loc"]) or "(top level)"
    kind = err["type"]
    given = err.get("input")
    if kind == "missing":
        return f"{loc}: required field is missing"
    if kind == "extra_forbidden":
        return f"{loc}: unknown field (given {given!r}); check the spelling against the documented fields"
    msg = err["msg"]
    ctx = err.get("ctx") or {}
    if kind == "finite_number":
        msg = "must be a finite number"
    elif "gt" in ctx or "ge" in ctx or "lt" in ctx or "le" in ctx:
        lo = f"> {ctx['gt']}" if "gt" in ctx else (f">= {ctx['ge']}" if "ge" in ctx else "")
        hi = f"< {ctx['lt']}" if "lt" in ctx else (f"<= {ctx['le']}" if "le" in ctx else "")
        msg = f"{msg} (allowed: {' and '.join(p for p in (lo, hi) if p)})"
    return f"{loc}: {msg}; given {given!r}"


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
        lines = [_describe_error(e) for e in exc.errors(include_url=False)]
        raise ConfigError(f"{source}: invalid {model.__name__}:\n  " + "\n  ".join(lines)) from None


def load_config(path: str | pathlib.Path, model: type[M]) -> M:
    """Read and validate a YAML configuration file.

    Args:
        path: the YAML file.
        model: the pydantic config class, e.g. :class:`RobotConfig`.

    Returns:
        The validated, frozen configuration.

    Raises:
        ConfigError: the file is missing, is not YAML, or a field is invalid.
    """
    path = pathlib.Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the {model.__name__} file ({exc.strerror})") from None
    try:
        data = yaml.load(text, Loader=_Loader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    return parse_config(data, model, source=str(path))
