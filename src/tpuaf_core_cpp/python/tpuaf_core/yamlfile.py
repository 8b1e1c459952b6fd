"""Strict YAML input files of the tpuaf packages (map, graph, map_server and world files).

Pure Python, here in the base package so that tpuaf and tpuaf_stage (which may not import
tpuaf) share one reader and one unknown-key check:

- `read_yaml` / `parse_yaml`: the document, every mapping and sequence carrying the 1-based
  `line` it starts on (see `line_of`); duplicate keys and non-scalar keys are refused;
- `where(name, node)`: "file:line" for messages;
- `check_keys`: a mapping with only the allowed keys.

Every error is one line naming the file (and line), raised as the caller's error class (a
TpuafError subclass).
"""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path
from typing import Any

import yaml

__all__ = ["check_keys", "line_of", "parse_yaml", "read_yaml", "where"]


class _LineDict(dict):
    line = 0  # 1-based line of the mapping in its file; 0: unknown


class _LineList(list):
    line = 0  # 1-based line of the sequence in its file; 0: unknown


class _Loader(yaml.SafeLoader):
    """Safe YAML loader that records the line of every mapping and sequence and refuses
    duplicate and unhashable (list, mapping, set) keys with `error_class`."""

    error_class: type[Exception] = ValueError


def _kind(value: Any) -> str:
    if isinstance(value, dict):
        return "mapping"
    return "list" if isinstance(value, list) else type(value).__name__


def _construct_map(loader: _Loader, node: yaml.MappingNode) -> _LineDict:
    out = _LineDict()
    out.line = node.start_mark.line + 1
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        at = f"{node.start_mark.name}:{key_node.start_mark.line + 1}"
        try:
            hash(key)
        except TypeError:
            raise loader.error_class(f"{at}: a mapping key must be a scalar, got a "
                                     f"{_kind(key)}") from None
        if key in out:
            raise loader.error_class(f"{at}: duplicate key {key!r}")
        out[key] = loader.construct_object(value_node, deep=True)
    return out


def _construct_seq(loader: _Loader, node: yaml.SequenceNode) -> _LineList:
    out = _LineList(loader.construct_object(child, deep=True) for child in node.value)
    out.line = node.start_mark.line + 1
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_map)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_seq)


def parse_yaml(text: str, name: str | Path, error_class: type[Exception], *,
               lines: bool = True) -> Any:
    """The YAML document in `text` (from file `name`, for messages).

    `lines`: the strict line-tracking loader (above); False: plain `yaml.safe_load` (duplicate
    keys allowed, the last one wins, as ROS map_server reads its files; no lines)."""
    try:
        if not lines:
            return yaml.safe_load(text)
        loader = _Loader(text)
        loader.name = str(name)  # the marks' file name
        loader.error_class = error_class
        try:
            return loader.get_single_data()
        finally:
            loader.dispose()
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        at = f":{mark.line + 1}" if mark is not None else ""
        raise error_class(f"{name}{at}: invalid YAML: {getattr(err, 'problem', None) or err}") \
            from None


def read_yaml(path: str | Path, error_class: type[Exception]) -> Any:
    """`parse_yaml` of the file at `path` (strict, with lines)."""
    try:
        text = Path(path).read_text()
    except OSError as err:
        raise error_class(f"{path}: cannot read: {err.strerror}") from None
    return parse_yaml(text, path, error_class)


def line_of(node: Any) -> int:
    """The 1-based line a mapping or sequence of `parse_yaml` starts on; 0 for anything else."""
    return int(getattr(node, "line", 0) or 0)


def where(name: str | Path, node: Any = None) -> str:
    """'name:line' of `node`, or 'name' when its line is unknown."""
    line = line_of(node)
    return f"{name}:{line}" if line else str(name)


def check_keys(node: Any, allowed: Collection[str], what: str | None, where: str,
               error_class: type[Exception]) -> None:
    """`node` must be a mapping whose keys are all in `allowed`; else `error_class` with a
    message starting with `where` (e.g. "file:line") and naming `what` (e.g. "vertex"; None:
    the whole file, named by `where` alone) and the valid keys."""
    if not isinstance(node, dict):
        raise error_class(f"{where}: {what or 'the file'} must be a mapping, got "
                          f"{type(node).__name__}")
    unknown = sorted(str(k) for k in set(node) - set(allowed))
    if unknown:
        inside = f" in {what}" if what else ""
        raise error_class(f"{where}: unknown key(s) {', '.join(unknown)}{inside} "
                          f"(valid: {', '.join(sorted(allowed))})")
