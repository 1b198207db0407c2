"""The shape of scripts/emdm, read from its source with ``ast`` (nothing is imported or run):

- no import cycle among emdm modules, imports inside functions included (a lazy import hides a cycle, it does not
  remove it);
- an ``emdm`` import inside a function says why on the line above it (or at its end): ``# lazy: <reason>`` (an
  optional or heavy module: torch in a numpy-only path, the ONNX exporter...); everything else sits at the top;
- no module imports another module's private (``_``) name;
- no source file over MAX_FILE_LINES lines, no function over MAX_FUNCTION_LINES lines without a
  ``# long: <reason>`` comment on the line above its ``def`` (or its first decorator).

Run ``python tests/python/test_structure.py`` to print every finding at once.
"""

from __future__ import annotations

import ast
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "scripts"
PACKAGE = "emdm"
MAX_FILE_LINES = 500
MAX_FUNCTION_LINES = 120



@dataclass(frozen=True)
class Import:
    source: str          # the importing module, e.g. "emdm.eval.report"
    target: str          # the imported module, e.g. "emdm.eval.results"
    names: tuple[str, ...]   # names taken from it ("from target import a, b"); () for "import target"
    path: str            # the importing file, relative to scripts/
    line: int
    in_function: bool
    comment: str         # the "# lazy:" reason found for it, "" when none


def module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def source_files(root: Path = ROOT) -> list[Path]:
    return sorted(p for p in (root / PACKAGE).rglob("*.py") if "__pycache__" not in p.parts)


def _modules(files: list[Path], root: Path = ROOT) -> set[str]:
    return {module_name(p, root) for p in files}


def _resolve(node: ast.Import | ast.ImportFrom, here: str, is_package: bool, modules: set[str]) -> list[tuple[str, tuple[str, ...]]]:
    """The emdm modules an import statement loads, each with the names it takes from it."""
    if isinstance(node, ast.Import):
        return [(a.name, ()) for a in node.names if a.name in modules]
    base = node.module or ""
    if node.level:
        pkg = here.split(".") if is_package else here.split(".")[:-1]
        pkg = pkg[: len(pkg) - (node.level - 1)]
        base = ".".join(pkg + ([base] if base else []))
    out: list[tuple[str, tuple[str, ...]]] = []
    taken: list[str] = []
    for a in node.names:
        sub = f"{base}.{a.name}"
        if sub in modules:
            out.append((sub, ()))          # "from emdm import manifest": the submodule itself
        else:
            taken.append(a.name)
    if taken and base in modules:
        out.append((base, tuple(taken)))
    return out


def _lazy_reason(lines: list[str], node: ast.stmt, import_lines: set[int]) -> str:
    """The "# lazy:" comment on the import's own line, or above it (over a block of imports directly above)."""
    own = lines[node.lineno - 1]
    if "# lazy:" in own:
        return own.split("# lazy:", 1)[1].strip()
    n = node.lineno - 1
    while n >= 1:
        text = lines[n - 1].strip()
        if "# lazy:" in text:
            return text.split("# lazy:", 1)[1].strip()
        if n not in import_lines:
            return ""
        n -= 1
    return ""


def imports_of(path: Path, modules: set[str], root: Path = ROOT) -> list[Import]:
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    tree = ast.parse(text, filename=str(path))
    here = module_name(path, root)
    is_package = path.name == "__init__.py"
    rel = path.relative_to(root).as_posix()
    found: list[tuple[ast.stmt, bool]] = []

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                found.append((child, in_function))
            visit(child, in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)))

    visit(tree, False)
    import_lines = {ln for node, _ in found for ln in range(node.lineno, (node.end_lineno or node.lineno) + 1)}
    out = []
    for node, in_function in found:
        reason = _lazy_reason(lines, node, import_lines) if in_function else ""
        for target, names in _resolve(node, here, is_package, modules):
            if target != here:
                out.append(Import(here, target, names, rel, node.lineno, in_function, reason))
    return out


def all_imports(root: Path = ROOT) -> list[Import]:
    files = source_files(root)
    modules = _modules(files, root)
    return [imp for p in files for imp in imports_of(p, modules, root)]


def import_cycles(imports: list[Import]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), each sorted."""
    graph: dict[str, set[str]] = {}
    for imp in imports:
        graph.setdefault(imp.source, set()).add(imp.target)
        graph.setdefault(imp.target, set())
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in sorted(graph):
        if v not in index:
            strong(v)
    return sorted(cycles)


def cycle_edges(imports: list[Import], cycle: list[str]) -> list[str]:
    members = set(cycle)
    return sorted({f"{i.path}:{i.line} {i.source} -> {i.target}" for i in imports
                   if i.source in members and i.target in members})


def unexplained_lazy_imports(imports: list[Import]) -> list[str]:
    return sorted({f"{i.path}:{i.line} imports {i.target} inside a function without a '# lazy: <reason>' comment"
                   for i in imports if i.in_function and not i.comment})


def private_imports(imports: list[Import]) -> list[str]:
    return sorted(f"{i.path}:{i.line} imports {n} (private to {i.target})"
                  for i in imports for n in i.names if n.startswith("_") and not n.startswith("__"))


def long_files(root: Path = ROOT) -> list[str]:
    out = []
    for p in source_files(root):
        n = len(p.read_text(encoding="utf-8").splitlines())
        if n > MAX_FILE_LINES:
            out.append(f"{p.relative_to(root).as_posix()}: {n} lines (at most {MAX_FILE_LINES})")
    return out


def long_functions(root: Path = ROOT) -> list[str]:
    out = []
    for p in source_files(root):
        text = p.read_text(encoding="utf-8")
        lines = text.splitlines()
        for node in ast.walk(ast.parse(text, filename=str(p))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            n = (node.end_lineno or node.lineno) - node.lineno + 1
            first = min([node.lineno] + [d.lineno for d in node.decorator_list])
            above = lines[first - 2] if first >= 2 else ""
            if n > MAX_FUNCTION_LINES and "# long:" not in above:
                out.append(f"{p.relative_to(root).as_posix()}:{node.lineno} {node.name}: {n} lines (at most "
                           f"{MAX_FUNCTION_LINES}, or a '# long: <reason>' comment on the line above its def)")
    return out


# ---- the tests ---------------------------------------------------------------------------------------------------------

def test_no_import_cycle():
    imports = all_imports()
    cycles = import_cycles(imports)
    assert not cycles, "import cycles among emdm modules:\n" + "\n".join(
        " <-> ".join(c) + "\n    " + "\n    ".join(cycle_edges(imports, c)) for c in cycles)


def test_every_lazy_emdm_import_says_why():
    bad = unexplained_lazy_imports(all_imports())
    assert not bad, "\n".join(bad)


def test_no_module_imports_a_private_name():
    bad = private_imports(all_imports())
    assert not bad, "\n".join(bad)


def test_no_source_file_over_the_limit():
    bad = [f for f in long_files()]
    assert not bad, "\n".join(bad)


def test_no_function_over_the_limit_without_a_reason():
    bad = [f for f in long_functions()]
    assert not bad, "\n".join(bad)


# ---- the checks themselves, on a small tree (each finds what it is for, and passes what it should) -------------------

def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        f = tmp_path / PACKAGE / rel
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text(text)
    return tmp_path


def test_a_cycle_through_a_lazy_import_is_found(tmp_path):
    root = _tree(tmp_path, {"__init__.py": "", "a.py": "from emdm.b import g\n",
                            "b.py": "def g():\n    from emdm import a  # lazy: hides the cycle\n    return a\n",
                            "c.py": "from emdm import a\n"})
    assert import_cycles(all_imports(root)) == [["emdm.a", "emdm.b"]]
    (root / PACKAGE / "b.py").write_text("def g():\n    return 1\n")
    assert import_cycles(all_imports(root)) == []


def test_a_lazy_emdm_import_needs_its_reason(tmp_path):
    root = _tree(tmp_path, {"__init__.py": "", "a.py": "X = 1\n", "_p.py": "",
                            "b.py": "import json\n\n\ndef f():\n    import numpy\n    from emdm.a import X\n    return X\n",
                            "c.py": "def f():\n    # lazy: torch, which a numpy-only path must not load\n"
                                    "    import json\n    from emdm.a import X\n    return X\n",
                            "d.py": "def f():\n    from emdm.a import X  # lazy: optional\n    return X\n"})
    assert unexplained_lazy_imports(all_imports(root)) == [
        "emdm/b.py:6 imports emdm.a inside a function without a '# lazy: <reason>' comment"]


def test_a_private_name_from_another_module_is_found(tmp_path):
    root = _tree(tmp_path, {"__init__.py": "", "a.py": "_x = 1\ny = 2\n", "b.py": "from emdm.a import _x, y\n",
                            "c.py": "from emdm.a import y\n"})
    assert private_imports(all_imports(root)) == ["emdm/b.py:1 imports _x (private to emdm.a)"]


def test_long_files_and_functions_are_found_unless_explained(tmp_path):
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES))
    root = _tree(tmp_path, {"__init__.py": "", "f.py": "def long():\n" + body,
                            "g.py": "# long: one table, row by row\ndef long():\n" + body,
                            "h.py": "def short():\n    return 1\n" + "\n" * MAX_FILE_LINES})
    assert [f.split(" ")[0] for f in long_functions(root)] == ["emdm/f.py:1"]
    assert [f.split(":")[0] for f in long_files(root)] == ["emdm/h.py"]


if __name__ == "__main__":
    imps = all_imports()
    for c in import_cycles(imps):
        print("cycle:", " <-> ".join(c))
        for e in cycle_edges(imps, c):
            print("   ", e)
    for line in unexplained_lazy_imports(imps) + private_imports(imps) + long_files() + long_functions():
        print(line)


def test_the_sampling_path_loads_no_torch():
    """`emdm-sample` and `emdm.generate` run in a no-torch install (pip's default extras): importing them must not
    import torch or scipy, directly or through a module they import (the prompt check once pulled in the eval
    classifier, and with it torch: 1.4 s per command, and a traceback without torch)."""
    import os
    import subprocess
    import sys

    code = ("import sys, emdm.sample, emdm.generation, emdm.prompt_check; "
            "print(sorted(m for m in ('torch', 'scipy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.stdout.strip() == "[]", out.stdout + out.stderr
