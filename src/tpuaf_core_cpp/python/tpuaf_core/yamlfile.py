"""Strict YAML input files of the tpuaf packages (map, graph, map_server and world files).

Pure Python, here in the base package so that tpuaf and tpuaf_stage (which may not import
tpuaf) share one reader and one unknown-key check:

- `read_yaml` / `parse_yaml`: the document, every mapping and sequence carrying the 1-based
  `line` it starts on (see `line_of`); duplicate keys and non-scalar keys are refused;
- `read_yaml_fast` / `parse_yaml_fast`: the same document through libyaml's C parser (when
  PyYAML has it; `HAS_LIBYAML`), about 10x faster, without lines; anything it doubts (invalid
  YAML, a duplicate or non-scalar key) is an error for the caller to re-read with `read_yaml`,
  whose message names the line;
- `where(name, node)`: "file:line" for messages;
- `check_keys`: a mapping with only the allowed keys.

Every error is one line naming the file (and line), raised as the caller's error class (a
TpuafError subclass).
"""

from __future__ import annotations

import re
import threading
from collections.abc import Collection
from pathlib import Path
from typing import Any

import yaml

__all__ = ["HAS_LIBYAML", "check_keys", "line_of", "parse_yaml", "parse_yaml_fast", "read_yaml",
           "read_yaml_fast", "where"]

HAS_LIBYAML = bool(getattr(yaml, "__with_libyaml__", False)) and hasattr(yaml, "CSafeLoader")


class _LineDict(dict):
    line = 0  # 1-based line of the mapping in its file; 0: unknown


class _LineList(list):
    line = 0  # 1-based line of the sequence in its file; 0: unknown


class _Loader(yaml.SafeLoader):
    """Safe YAML loader that records the line of every mapping and sequence and refuses
    duplicate and unhashable (list, mapping, set) keys with `error_class`."""

    error_class: type[Exception] = ValueError

    def construct_object(self, node: yaml.Node, deep: bool = False) -> Any:
        """PyYAML's, with a value it cannot build (e.g. the date 2001-13-45, `!!int x`) as
        `error_class` naming the line instead of a bare ValueError."""
        try:
            return super().construct_object(node, deep)
        except self.error_class:
            raise
        except (ValueError, TypeError, OverflowError) as err:
            what = f"{node.value!r} " if isinstance(node, yaml.ScalarNode) else ""
            raise self.error_class(f"{self.name}:{node.start_mark.line + 1}: invalid YAML: "
                                   f"cannot read {what}as {node.tag.rsplit(':', 1)[-1]} "
                                   f"({err})") from None


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
    except RecursionError:
        raise error_class(f"{name}: invalid YAML: collections nested too deeply") from None


def read_yaml(path: str | Path, error_class: type[Exception]) -> Any:
    """`parse_yaml` of the file at `path` (strict, with lines)."""
    return parse_yaml(_read_text(path, error_class), path, error_class)


def _read_text(path: str | Path, error_class: type[Exception]) -> str:
    try:
        return Path(path).read_text()
    except OSError as err:
        raise error_class(f"{path}: cannot read: {err.strerror}") from None


# ------------------------------------------------------------------------------- fast reader
# libyaml scans, parses and composes in C; PyYAML's constructor (Python) builds the values,
# here plain dicts and lists: no lines, so a caller validates the result and, on any problem,
# re-reads the file with `read_yaml` for the message with its line.


class _Doubt(Exception):
    """The fast reader cannot vouch for the document (the strict reader decides)."""


_TAG = "tag:yaml.org,2002:"
_SCALARS = {_TAG + kind: getattr(yaml.SafeLoader, f"construct_yaml_{kind}")
            for kind in ("null", "bool", "int", "float", "str")}  # values of node.value alone


def _fast_value(loader: Any, node: yaml.Node) -> Any:
    if type(node) is yaml.ScalarNode:
        make = _SCALARS.get(node.tag)
        if make is not None:  # an immutable value: no need of construct_object's cache
            return make(loader, node)
    return loader.construct_object(node, deep=True)


def _fast_map(loader: Any, node: yaml.MappingNode) -> dict:
    out: dict = {}
    try:
        for key_node, value_node in node.value:
            key = _fast_value(loader, key_node)
            out[key] = _fast_value(loader, value_node)
    except TypeError:
        raise _Doubt("a mapping key must be a scalar") from None
    if len(out) != len(node.value):  # libyaml keeps the last of two equal keys
        raise _Doubt("duplicate key")
    return out


def _fast_seq(loader: Any, node: yaml.SequenceNode) -> list:
    return [_fast_value(loader, child) for child in node.value]


if HAS_LIBYAML:
    class _FastLoader(yaml.CSafeLoader):
        """libyaml's parser, plain containers, duplicate and unhashable keys refused."""

    _FastLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _fast_map)
    _FastLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _fast_seq)

# libyaml reads a few texts that PyYAML's scanner refuses (tabs as separators, '?' and tags
# inside flow collections, ...): the fast reader takes only printable ASCII and line breaks,
# without the indicators '?', '!', '%', '@', '`' (our writer never writes them); any other
# text goes to the strict reader.
_NOT_PLAIN = re.compile(r"[^\n\r -~]|[?!%@`]")


# libyaml's composer recurses on the C stack (about 250 bytes a level): a document nested
# some 30,000 levels deep overflows a thread's 8 MB stack. Nesting depth <= the flow openers
# ('[' '{') plus two block levels per column of the longest line; beyond _MAX_DEPTH_HERE the
# C parser runs in a thread with a stack sized for that bound.
_MAX_DEPTH_HERE = 10_000
_STACK_BYTES_PER_LEVEL = 1024  # [B], four times what a level takes
_MAX_STACK_BYTES = 1 << 30


def _depth_bound(text: str) -> int:
    longest = max(map(len, text.splitlines()), default=0)
    return text.count("[") + text.count("{") + 2 * (longest + 1)


def _fast_load(text: str) -> Any:
    loader = _FastLoader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


def _fast_load_deep(text: str, depth: int) -> Any:
    """_fast_load in a thread whose stack holds `depth` levels of nesting."""
    result: dict[str, Any] = {}

    def work() -> None:
        try:
            result["doc"] = _fast_load(text)
        except BaseException as err:  # noqa: BLE001 - handed to the calling thread
            result["error"] = err

    previous = threading.stack_size(depth * _STACK_BYTES_PER_LEVEL + (1 << 20))
    try:
        thread = threading.Thread(target=work, name="yaml-deep", daemon=True)
        thread.start()
    finally:
        threading.stack_size(previous)
    thread.join()
    if "error" in result:
        raise result["error"]
    return result["doc"]


def parse_yaml_fast(text: str, name: str | Path, error_class: type[Exception]) -> Any:
    """The document in `text` as `parse_yaml` reads it, without lines (plain dicts and lists;
    `line_of` gives 0), through libyaml's C parser when PyYAML has it and the text is plain
    (else `parse_yaml` itself, with lines).

    Raises `error_class` ("name: ...", no line) for anything `parse_yaml` might read
    differently: invalid YAML, duplicate or non-scalar keys, any failure to build a value. A
    caller that meets an error (here or in its own checks of the document) re-reads with
    `parse_yaml` for the message naming the line."""
    if not HAS_LIBYAML or _NOT_PLAIN.search(text):
        return parse_yaml(text, name, error_class)
    try:
        depth = _depth_bound(text)
        if depth <= _MAX_DEPTH_HERE:
            return _fast_load(text)
        if depth * _STACK_BYTES_PER_LEVEL <= _MAX_STACK_BYTES:
            return _fast_load_deep(text, depth)
    except Exception as err:  # noqa: BLE001 - any doubt: the strict reader decides
        problem = getattr(err, "problem", None) or err
        raise error_class(f"{name}: not read by libyaml ({problem}); read it with read_yaml "
                          "for the line") from None
    return parse_yaml(text, name, error_class)  # too deep for any sensible stack


def read_yaml_fast(path: str | Path, error_class: type[Exception]) -> Any:
    """`parse_yaml_fast` of the file at `path`."""
    return parse_yaml_fast(_read_text(path, error_class), path, error_class)


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
