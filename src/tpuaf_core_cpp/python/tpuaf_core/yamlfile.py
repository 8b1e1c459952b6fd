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

Files are data, not trusted: only regular files are read (`read_regular_bytes`: no FIFO,
device or link loop), at most MAX_YAML_BYTES, as UTF-8 (a bad byte is named with its line);
documents nest at most MAX_NESTING levels.

Every error is one line naming the file (and line), raised as the caller's error class (a
TpuafError subclass).
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Collection
from pathlib import Path
from typing import Any

import yaml

__all__ = ["HAS_LIBYAML", "MAX_NESTING", "MAX_YAML_BYTES", "check_keys", "decode_utf8", "line_of",
           "parse_yaml", "parse_yaml_fast", "read_regular_bytes", "read_yaml", "read_yaml_fast",
           "shorten", "where"]

MAX_YAML_BYTES = 64 << 20  # a 10,000-vertex graph file is about 1 MB
MAX_NESTING = 64  # mappings and sequences inside each other (our files: 5 at most)

HAS_LIBYAML = bool(getattr(yaml, "__with_libyaml__", False)) and hasattr(yaml, "CSafeLoader")


class _LineDict(dict):
    line = 0  # 1-based line of the mapping in its file; 0: unknown


class _LineList(list):
    line = 0  # 1-based line of the sequence in its file; 0: unknown


class _NestingCap:
    """compose_node with at most MAX_NESTING levels (deeper: error_class naming the line,
    before Python's recursion limit is reached)."""

    error_class: type[Exception] = ValueError
    name = ""
    _depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._depth += 1
        try:
            if self._depth > MAX_NESTING:
                mark = self.peek_event().start_mark
                raise self.error_class(f"{self.name}:{mark.line + 1}: invalid YAML: nested more "
                                       f"than {MAX_NESTING} levels deep")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


class _Loader(_NestingCap, yaml.SafeLoader):
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
                                   f"cannot read {shorten(what)}as {node.tag.rsplit(':', 1)[-1]} "
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


class _PlainLoader(_NestingCap, yaml.SafeLoader):
    """yaml.safe_load's loader (the last of two equal keys wins) with the nesting cap."""


def parse_yaml(text: str, name: str | Path, error_class: type[Exception], *,
               lines: bool = True) -> Any:
    """The YAML document in `text` (from file `name`, for messages).

    `lines`: the strict line-tracking loader (above); False: plain `yaml.safe_load` (duplicate
    keys allowed, the last one wins, as ROS map_server reads its files; no lines)."""
    try:
        loader = (_Loader if lines else _PlainLoader)(text)
        loader.name = str(name)  # the marks' file name
        loader.error_class = error_class
        try:
            return loader.get_single_data()
        finally:
            loader.dispose()
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        at = f":{mark.line + 1}" if mark is not None else ""
        raise error_class(f"{name}{at}: invalid YAML: "
                          f"{shorten(str(getattr(err, 'problem', None) or err))}") from None
    except RecursionError:
        raise error_class(f"{name}: invalid YAML: collections nested too deeply") from None


def read_yaml(path: str | Path, error_class: type[Exception]) -> Any:
    """`parse_yaml` of the file at `path` (strict, with lines)."""
    return parse_yaml(_read_text(path, error_class), path, error_class)


def _read_text(path: str | Path, error_class: type[Exception]) -> str:
    return decode_utf8(read_regular_bytes(path, error_class, max_bytes=MAX_YAML_BYTES), path,
                       error_class)


_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def _not_regular(mode: int) -> str | None:
    if stat.S_ISREG(mode):
        return None
    return next((kind for test, kind in _KINDS if test(mode)), "not a regular file")


def read_regular_bytes(path: str | Path, error_class: type[Exception], *, max_bytes: int,
                       what: str = "file") -> bytes:
    """The bytes of the regular file at `path` (a link to one is fine), at most `max_bytes`.
    A FIFO, device, socket or folder, a link loop or a larger file is `error_class` in one
    line, without blocking (the file is opened non-blocking and checked again once open)."""
    try:
        mode = os.stat(path).st_mode  # follows links; a loop is ELOOP
        kind = _not_regular(mode)
        if kind is None:
            fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
        else:
            fd = -1
    except OSError as err:
        raise error_class(f"{path}: cannot read {what}: {err.strerror or err}") from None
    if fd < 0:
        raise error_class(f"{path}: is {kind}, not a regular {what}")
    try:
        st = os.fstat(fd)
        kind = _not_regular(st.st_mode)  # swapped between stat and open
        if kind is not None:
            raise error_class(f"{path}: is {kind}, not a regular {what}")
        if st.st_size > max_bytes:
            raise error_class(f"{path}: {st.st_size:,} bytes, more than the {max_bytes:,} a "
                              f"{what} may have")
        chunks, total = [], 0
        while total <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > max_bytes:
            raise error_class(f"{path}: more than the {max_bytes:,} bytes a {what} may have")
        return b"".join(chunks)
    except OSError as err:
        raise error_class(f"{path}: cannot read {what}: {err.strerror or err}") from None
    finally:
        os.close(fd)


def decode_utf8(data: bytes, path: str | Path, error_class: type[Exception]) -> str:
    """`data` as UTF-8 text; a byte that is not is `error_class` naming the line and column."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        column = err.start - (data.rfind(b"\n", 0, err.start) + 1) + 1
        raise error_class(f"{path}:{line}: not UTF-8 text (byte 0x{data[err.start]:02x} at "
                          f"column {column})") from None


def shorten(text: str, limit: int = 80) -> str:
    """`text` with every run of more than `limit` characters without a space cut to its start
    and its length, for messages that quote a user's token."""
    if len(text) <= limit:
        return text
    return re.sub(rf"\S{{{limit + 1},}}",
                  lambda m: f"{m.group(0)[:limit // 2]}... ({len(m.group(0)):,} characters)",
                  text)


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


# libyaml's composer recurses on the C stack; the fast reader takes only texts whose nesting
# is surely within MAX_NESTING: at most the deepest flow nesting ('[' '{', quoted ones
# counted too) plus the longest run of indentation and '- ' starting a line. Anything deeper
# goes to the strict reader, which counts exactly.
_FLOW = re.compile(r"[^\[\]{}]+")
_BLOCK = re.compile(r"^[ -]*", re.M)


def _nesting_bound(text: str) -> int:
    depth = deepest = 0
    for c in _FLOW.sub("", text):
        depth += 1 if c in "[{" else -1
        deepest = max(deepest, depth)
    block = max(map(len, _BLOCK.findall(text)), default=0)
    return deepest + block + 1


def _fast_load(text: str) -> Any:
    loader = _FastLoader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


def parse_yaml_fast(text: str, name: str | Path, error_class: type[Exception]) -> Any:
    """The document in `text` as `parse_yaml` reads it, without lines (plain dicts and lists;
    `line_of` gives 0), through libyaml's C parser when PyYAML has it and the text is plain
    (else `parse_yaml` itself, with lines).

    Raises `error_class` ("name: ...", no line) for anything `parse_yaml` might read
    differently: invalid YAML, duplicate or non-scalar keys, any failure to build a value. A
    caller that meets an error (here or in its own checks of the document) re-reads with
    `parse_yaml` for the message naming the line."""
    if not HAS_LIBYAML or _NOT_PLAIN.search(text) or _nesting_bound(text) > MAX_NESTING:
        return parse_yaml(text, name, error_class)
    try:
        return _fast_load(text)
    except Exception as err:  # noqa: BLE001 - any doubt: the strict reader decides
        problem = getattr(err, "problem", None) or err
        raise error_class(f"{name}: not read by libyaml ({shorten(str(problem))}); read it "
                          "with read_yaml for the line") from None


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
