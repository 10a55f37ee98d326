"""YAML files checked by pydantic models, with one-line errors naming the field (scenarios, detector
configs, QA tolerances).

`read_yaml` is the project's only YAML reader. It refuses, in one line and before building anything
large, what could make it slow or large: a file that is not a regular file or is over `MAX_YAML_BYTES`,
nesting deeper than `MAX_YAML_DEPTH`, aliases that expand to more than `MAX_YAML_NODES` nodes (a
"billion laughs") or into themselves, and duplicate keys (which YAML would otherwise settle silently,
the last one winning).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from simgen.errors import UserError

Model = TypeVar("Model", bound=BaseModel)

MAX_YAML_BYTES = 1 << 20  # 1 MiB: our largest YAML file is under 4 KiB
MAX_YAML_DEPTH = 32  # nested mappings and lists; a scenario needs 7
MAX_YAML_NODES = 100_000  # scalars, mappings and lists once aliases are expanded

class Strict(BaseModel):
    """Base of every validated file's models: unknown keys, NaN and infinity refused; frozen once read."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml when installed: 1 MiB parses in ~0.1 s


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


def validate(model: type[Model], data: object, source: str, context: dict | None = None) -> Model:
    """`model` from a parsed YAML document; `UserError` naming the first bad field."""
    if not isinstance(data, dict):
        raise UserError(f"{source}: expected a mapping of keys at the top level")
    try:
        return model.model_validate(data, context=context)
    except ValidationError as error:
        extra = f" (and {error.error_count() - 1} more)" if error.error_count() > 1 else ""
        raise UserError(f"{source}: {' '.join(one_line(error).splitlines())}{extra}") from None


def read_limited(path: str | Path, kind: str, max_bytes: int) -> bytes:
    """The bytes of a regular file of at most `max_bytes`; anything else is a one-line `UserError`.

    Checked before reading: a device (/dev/zero), a FIFO or a directory is never opened for reading.
    """
    path = Path(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise UserError(f"{path}: no such {kind} file") from None
    except OSError as error:
        raise UserError(f"{path}: cannot read ({error.strerror})") from None
    if stat.S_ISDIR(info.st_mode):
        raise UserError(f"{path}: is a directory, not a {kind} file")
    if not stat.S_ISREG(info.st_mode):
        raise UserError(f"{path}: not a regular file (a device, FIFO or socket), not a {kind} file")
    if info.st_size > max_bytes:
        raise UserError(f"{path}: {info.st_size:,} bytes, a {kind} file may have at most {max_bytes:,}")
    try:
        with open(path, "rb") as stream:
            data = stream.read(max_bytes + 1)  # a file that grew since stat
    except OSError as error:
        raise UserError(f"{path}: cannot read ({error.strerror})") from None
    if len(data) > max_bytes:
        raise UserError(f"{path}: over {max_bytes:,} bytes, a {kind} file may have at most {max_bytes:,}")
    return data


class _UniqueKeyLoader(_Loader):
    """The safe loader, refusing a key given twice in one mapping."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                duplicate = key in seen
                seen.add(key)
            except TypeError:  # an unhashable key: let the safe loader say so
                break
            if duplicate:
                mark = key_node.start_mark
                shown = str(key).encode("unicode_escape").decode("ascii")[:40]
                raise yaml.constructor.ConstructorError(None, None, f"duplicate key '{shown}'", mark)
        return super().construct_mapping(node, deep=deep)


def _check_shape(text: str) -> None:
    """Refuse nesting beyond MAX_YAML_DEPTH from the event stream (no recursion, no objects built)."""
    depth = 0
    for event in yaml.parse(text, Loader=_Loader):
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > MAX_YAML_DEPTH:
                raise _Refused(f"nested deeper than {MAX_YAML_DEPTH} levels", event.start_mark)
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1


def _check_expansion(root: yaml.Node) -> None:
    """Refuse aliases that expand beyond MAX_YAML_NODES nodes or MAX_YAML_DEPTH levels, or into themselves."""
    size: dict[int, tuple[int, int]] = {}  # id(node) -> (nodes, depth) once expanded
    on_path: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:  # post-order walk without recursion, each distinct node once
        node, children_done = stack.pop()
        key = id(node)
        if isinstance(node, yaml.ScalarNode):
            size[key] = (1, 0)
            continue
        children = [n for pair in node.value for n in pair] if isinstance(node, yaml.MappingNode) else node.value
        if children_done:
            on_path.discard(key)
            nodes = 1 + sum(size[id(c)][0] for c in children)
            depth = 1 + max((size[id(c)][1] for c in children), default=0)
            if nodes > MAX_YAML_NODES:
                raise _Refused(f"aliases expand to more than {MAX_YAML_NODES:,} nodes", node.start_mark)
            if depth > MAX_YAML_DEPTH:
                raise _Refused(f"aliases expand to nesting deeper than {MAX_YAML_DEPTH} levels", node.start_mark)
            size[key] = (nodes, depth)
            continue
        if key in size:
            continue
        if key in on_path:
            raise _Refused("an alias refers to a node that contains it", node.start_mark)
        on_path.add(key)
        stack.append((node, True))
        stack.extend((c, False) for c in children if id(c) not in size)
        for child in children:
            if id(child) in on_path:
                raise _Refused("an alias refers to a node that contains it", child.start_mark)


class _Refused(Exception):
    def __init__(self, problem: str, mark) -> None:
        super().__init__(problem)
        self.problem, self.problem_mark = problem, mark


def parse_yaml(text: str, source: str) -> object:
    """The document of a YAML text, within the limits above; `UserError` naming the line otherwise."""
    try:
        _check_shape(text)
        loader = _UniqueKeyLoader(text)
        try:
            root = loader.get_single_node()
            if root is None:
                return None
            _check_expansion(root)
            return loader.construct_document(root)
        finally:
            loader.dispose()
    except (yaml.YAMLError, _Refused) as error:
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(error, "problem", None) or "malformed YAML"
        kind = (
            "refused YAML" if isinstance(error, _Refused) or problem.startswith("duplicate key") else "malformed YAML"
        )
        raise UserError(f"{source}: {kind}{where}: {' '.join(str(problem).splitlines())}") from None
    except (ValueError, OverflowError, RecursionError) as error:  # e.g. an integer of 10,000 digits
        raise UserError(f"{source}: refused YAML: {' '.join(str(error).splitlines())[:120]}") from None


def read_yaml(path: str | Path, kind: str) -> object:
    """The parsed YAML document of a `kind` file ("scenario", "config", "tolerances"); `UserError` when it cannot be."""
    data = read_limited(path, kind, MAX_YAML_BYTES)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise UserError(f"{path}: not UTF-8 text (byte {error.start})") from None
    return parse_yaml(text, str(path))
