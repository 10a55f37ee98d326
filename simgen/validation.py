"""YAML files checked by pydantic models, with one-line errors naming the field (scenarios, detector configs)."""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from simgen.errors import UserError

Model = TypeVar("Model", bound=BaseModel)


def _field_path(location: tuple) -> str:
    """Dotted path of a field; control characters in user-given keys are escaped to keep one line."""
    return ".".join(str(part).encode("unicode_escape").decode("ascii") for part in location) or "(top level)"


def one_line(error: ValidationError) -> str:
    """The first problem of a validation error, in one line that names the field."""
    first = error.errors()[0]
    if not first["loc"]:  # a check across sections: its message names the fields
        return first["msg"].removeprefix("Value error, ")
    field = _field_path(first["loc"])
    if first["type"] == "value_error":
        return f"'{field}': {first['msg'].removeprefix('Value error, ')}"
    if first["type"] == "extra_forbidden":
        return f"unknown key '{field}'"
    if first["type"] == "missing":
        return f"missing key '{field}'"
    value = repr(first.get("input"))
    return f"'{field}': {first['msg']} (got {value[:60]}{'...' if len(value) > 60 else ''})"


def validate(model: type[Model], data: object, source: str) -> Model:
    """`model` from a parsed YAML document; `UserError` naming the first bad field."""
    if not isinstance(data, dict):
        raise UserError(f"{source}: expected a mapping of keys at the top level")
    try:
        return model.model_validate(data)
    except ValidationError as error:
        extra = f" (and {error.error_count() - 1} more)" if error.error_count() > 1 else ""
        raise UserError(f"{source}: {one_line(error)}{extra}") from None


def read_yaml(path: str | Path, kind: str) -> object:
    """The parsed YAML document of a `kind` file ("scenario", "config"); `UserError` when it cannot be."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UserError(f"{path}: no such {kind} file") from None
    except IsADirectoryError:
        raise UserError(f"{path}: is a directory, not a {kind} file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise UserError(f"{path}: cannot read ({error.__class__.__name__}: {error})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(error, "problem", None) or "malformed YAML"
        raise UserError(f"{path}: malformed YAML{where}: {problem}") from None
