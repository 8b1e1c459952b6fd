"""Files that do one job (issue 31): no source file over 600 lines, no Python function over 80
lines without a reason.

- Python under src/: a file of at most MAX_FILE_LINES lines; a function (decorators included)
  of at most MAX_FUNCTION_LINES lines, or a `# long: <reason>` comment on its `def` line or on
  the comment lines just above it (above its decorators).
- C++ under src/tpuaf_core_cpp and src/tpuaf_stage: a file of at most MAX_FILE_LINES lines; a
  function defined at namespace level (clang-format style: its closing `}` in column 0) of at
  most MAX_FUNCTION_LINES lines, or a `// long: <reason>` comment on its first line or on the
  comment lines just above it.

`.venv/bin/python tests/test_code_shape.py` lists every file and function over the limits,
the allowed ones included.
"""

from __future__ import annotations

import ast
import fnmatch
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
CPP_FOLDERS = (SRC / "tpuaf_core_cpp", SRC / "tpuaf_stage")
CPP_SUFFIXES = (".cpp", ".hpp", ".h", ".cc")
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 80
LONG = re.compile(r"#\s*long:\s*\S")  # the reason a function may be longer
CPP_LONG = re.compile(r"//\s*long:\s*\S")
# a line in column 0 that starts a definition (not a directive, comment, namespace or type)
CPP_NOT_A_FUNCTION = ("#", "//", "/*", " *", "namespace", "}", "class ", "struct ", "enum ",
                      "using ", "typedef ", "extern ", "static_assert", "template")

# Being split in another branch: the lead removes these once those branches are merged.
ALLOWED = (
)


def _allowed(path: Path) -> bool:
    rel = path.relative_to(ROOT).as_posix()
    return any(fnmatch.fnmatchcase(rel, pattern) for pattern in ALLOWED)


def python_files() -> list[Path]:
    return sorted(p for p in SRC.rglob("*.py") if "__pycache__" not in p.parts)


def cpp_files() -> list[Path]:
    return sorted(p for folder in CPP_FOLDERS for p in folder.rglob("*")
                  if p.suffix in CPP_SUFFIXES and p.is_file())


def line_count(path: Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def has_reason(lines: list[str], node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """A `# long:` comment on the def line or among the comment lines just above it."""
    if LONG.search(lines[node.lineno - 1]):
        return True
    first = min([node.lineno] + [d.lineno for d in node.decorator_list])
    i = first - 2  # the line above, 0-based
    while i >= 0 and lines[i].strip().startswith("#"):
        if LONG.search(lines[i]):
            return True
        i -= 1
    return False


def long_functions(path: Path) -> list[tuple[str, int, int, bool]]:
    """(name, def line, length in lines, has a reason) of every function over the limit."""
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    out = []
    for node in ast.walk(ast.parse(text, str(path))):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            first = min([node.lineno] + [d.lineno for d in node.decorator_list])
            length = node.end_lineno - first + 1
            if length > MAX_FUNCTION_LINES:
                out.append((node.name, node.lineno, length, has_reason(lines, node)))
    return out


def long_cpp_functions(path: Path) -> list[tuple[str, int, int, bool]]:
    """(first line's text, first line, length in lines, has a reason) of every namespace-level
    C++ function over the limit: from its first line (in column 0) to its `}` in column 0."""
    lines = path.read_text(encoding="utf-8").splitlines()
    out = []
    i = 0
    while i < len(lines):
        line = lines[i]
        if not line or line[0].isspace() or line.startswith(CPP_NOT_A_FUNCTION) \
                or "(" not in line:
            i += 1
            continue
        j = i
        while j < len(lines) and not lines[j].rstrip().endswith(("{", ";")):
            j += 1
        if j == len(lines) or lines[j].rstrip().endswith(";"):  # a declaration
            i = j + 1
            continue
        k = j + 1
        while k < len(lines) and not lines[k].startswith("}"):
            k += 1
        length = k - i + 1
        if length > MAX_FUNCTION_LINES:
            reason = bool(CPP_LONG.search(line))
            above = i - 1
            while not reason and above >= 0 and lines[above].lstrip().startswith("//"):
                reason = bool(CPP_LONG.search(lines[above]))
                above -= 1
            out.append((line.split("(")[0], i + 1, length, reason))
        i = k + 1
    return out


def test_no_source_file_over_the_limit():
    big = [f"{p.relative_to(ROOT)}: {n} lines" for p in python_files() + cpp_files()
           if (n := line_count(p)) > MAX_FILE_LINES and not _allowed(p)]
    assert not big, (f"files over {MAX_FILE_LINES} lines (split them along their jobs):\n"
                     + "\n".join(big))


def test_no_long_python_function_without_a_reason():
    bad = [f"{p.relative_to(ROOT)}:{line} {name}: {length} lines"
           for p in python_files() if not _allowed(p)
           for name, line, length, reason in long_functions(p) if not reason]
    assert not bad, (f"functions over {MAX_FUNCTION_LINES} lines without a `# long: <reason>` "
                     "comment on their def line or just above (split them, or say why not):\n"
                     + "\n".join(bad))


def test_no_long_cpp_function_without_a_reason():
    bad = [f"{p.relative_to(ROOT)}:{line} {name}: {length} lines"
           for p in cpp_files() if p.suffix in (".cpp", ".cc") and not _allowed(p)
           for name, line, length, reason in long_cpp_functions(p) if not reason]
    assert not bad, (f"C++ functions over {MAX_FUNCTION_LINES} lines without a `// long: <reason>`"
                     " comment on their first line or just above (split them, or say why not):\n"
                     + "\n".join(bad))


def test_the_cpp_check_finds_what_it_looks_for(tmp_path):
    body = "".join(f"  int x{i} = {i};\n" for i in range(MAX_FUNCTION_LINES))
    source = ("#include <x>\n\nint short_one() { return 1; }\n\nint declared(int a);\n\n"
              f"int long_one(int a,\n             int b) {{\n{body}}}\n\n"
              f"// one table of values\n// long: a binding list, read top to bottom\n"
              f"void explained() {{\n{body}}}\n\nnamespace {{\nstruct S {{\n{body}}};\n}}\n")
    path = tmp_path / "sample.cpp"
    path.write_text(source)
    found = {name: reason for name, _, _, reason in long_cpp_functions(path)}
    assert found == {"int long_one": False, "void explained": True}


def test_the_checks_find_what_they_look_for(tmp_path):
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES))
    source = (f"def short():\n    return 1\n\n\ndef long_one():\n{body}\n\n"
              f"# long: one table of values, read top to bottom\n@staticmethod\n"
              f"def explained():\n{body}\n\ndef inline():  # long: a reason\n{body}")
    path = tmp_path / "sample.py"
    path.write_text(source)
    found = {name: reason for name, _, _, reason in long_functions(path)}
    assert found == {"long_one": False, "explained": True, "inline": True}
    assert line_count(path) == len(source.splitlines())


def test_the_allowances_name_existing_files():
    """Each allowance matches a file (a stale one is removed, not kept)."""
    files = [p.relative_to(ROOT).as_posix() for p in python_files() + cpp_files()]
    stale = [a for a in ALLOWED if not any(fnmatch.fnmatchcase(f, a) for f in files)]
    assert not stale, f"allowances matching no file: {stale}"


if __name__ == "__main__":
    for p in python_files() + cpp_files():
        n = line_count(p)
        mark = " (allowed)" if _allowed(p) else ""
        if n > MAX_FILE_LINES:
            print(f"file {n:5d} lines  {p.relative_to(ROOT)}{mark}")
        for name, line, length, reason in (long_functions(p) if p.suffix == ".py"
                                           else long_cpp_functions(p)):
            if True:
                why = " (reason given)" if reason else ""
                print(f"function {length:4d} lines  {p.relative_to(ROOT)}:{line} {name}{why}{mark}")
    sys.exit(0)
