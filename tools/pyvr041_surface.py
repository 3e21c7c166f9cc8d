"""Derive pyvr 0.4.1's public surface from its source, statically.

    python tools/pyvr041_surface.py PATH/TO/pyvr-0.4.1 > tests/compat/pyvr041_surface.json

PATH is a checkout of pyvr 0.4.1 (the directory holding its ``pyvr``
package). Nothing of it is imported or run: the source is parsed with
``ast``, so neither OpenGL nor VTK is needed. What is recorded, per module
of the package:

- ``names``: the public names (``__all__`` where the module has one, else
  its public functions, classes and relative re-exports);
- ``callables``: every public function, method, classmethod, staticmethod
  and property, with its parameters (name, kind, default as source text);
- ``classes``: bases, the public attributes ``__init__`` assigns to
  ``self``, and a dataclass's fields with their defaults;
- ``messages``: the literal text of every ``raise X("...")``, ``print``,
  ``warnings.warn`` and ``__repr__``/``__str__`` result (the parts outside
  ``{}`` placeholders), with where it is and which exception class.

``tests/compat/test_pyvr041_surface.py`` checks pyvr against this record;
the differences that are intended are listed in ``docs/migration.toml``.
"""

import ast
import json
import sys
from pathlib import Path

KINDS = {"posonlyargs": "POSITIONAL_ONLY", "args": "POSITIONAL_OR_KEYWORD", "kwonlyargs": "KEYWORD_ONLY"}


def params(fn: ast.FunctionDef) -> list:
    a = fn.args
    out = []
    positional = a.posonlyargs + a.args
    defaults = [None] * (len(positional) - len(a.defaults)) + list(a.defaults)
    for arg, default in zip(positional, defaults):
        kind = "POSITIONAL_ONLY" if arg in a.posonlyargs else "POSITIONAL_OR_KEYWORD"
        out.append([arg.arg, kind, None if default is None else ast.unparse(default)])
    if a.vararg:
        out.append([a.vararg.arg, "VAR_POSITIONAL", None])
    for arg, default in zip(a.kwonlyargs, a.kw_defaults):
        out.append([arg.arg, "KEYWORD_ONLY", None if default is None else ast.unparse(default)])
    if a.kwarg:
        out.append([a.kwarg.arg, "VAR_KEYWORD", None])
    return out


def decorator_names(node) -> list:
    return [ast.unparse(d).split("(")[0] for d in node.decorator_list]


def public(name: str) -> bool:
    return not name.startswith("_") or name == "__init__"


def literal_parts(node) -> list:
    """The literal text of a message expression, split at its placeholders."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, ast.JoinedStr):
        parts, current = [], ""
        for v in node.values:
            if isinstance(v, ast.Constant):
                current += v.value
            else:
                parts.append(current)
                current = ""
        parts.append(current)
        return parts
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        left, right = literal_parts(node.left), literal_parts(node.right)
        if left and right:
            return left[:-1] + [left[-1] + right[0]] + right[1:]
        return left + [""] + right
    return []


class Module(ast.NodeVisitor):
    def __init__(self, name: str):
        self.name = name
        self.callables, self.classes, self.messages = {}, {}, []
        self.scope = [name]

    def where(self) -> str:
        return ".".join(self.scope)

    def visit_ClassDef(self, node):
        if not public(node.name):
            return
        qual = f"{self.where()}.{node.name}"
        info = {"bases": [ast.unparse(b) for b in node.bases], "init_attributes": [], "fields": {}}
        if "dataclass" in decorator_names(node):
            init = [["self", "POSITIONAL_OR_KEYWORD", None]]
            for stmt in node.body:
                if isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name) and public(stmt.target.id):
                    default = None if stmt.value is None else ast.unparse(stmt.value)
                    init.append([stmt.target.id, "POSITIONAL_OR_KEYWORD", default])
                    info["fields"][stmt.target.id] = default
            # The __init__ the dataclass decorator writes: its public fields, in order.
            self.callables[f"{qual}.__init__"] = {"kind": "function", "params": init}
        for stmt in node.body:
            if isinstance(stmt, ast.FunctionDef) and stmt.name == "__init__":
                for sub in ast.walk(stmt):
                    targets = sub.targets if isinstance(sub, ast.Assign) else [sub.target] if isinstance(sub, ast.AnnAssign) else []
                    for t in targets:
                        if (isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name) and t.value.id == "self"
                                and not t.attr.startswith("_") and t.attr not in info["init_attributes"]):
                            info["init_attributes"].append(t.attr)
        self.classes[qual] = info
        self.scope.append(node.name)
        self.generic_visit(node)
        self.scope.pop()

    def visit_FunctionDef(self, node):
        in_class = len(self.scope) > 1 and self.scope[-1][:1].isupper()
        if public(node.name) and (in_class or len(self.scope) == 1):
            decorators = decorator_names(node)
            kind = next((d for d in ("classmethod", "staticmethod", "property") if d in decorators), "function")
            if kind == "function" and any(d.endswith(".setter") for d in decorators):
                kind = "setter"
            if kind != "setter":
                self.callables[f"{self.where()}.{node.name}"] = {"kind": kind, "params": params(node)}
        self.scope.append(node.name)
        self.generic_visit(node)
        self.scope.pop()

    visit_AsyncFunctionDef = visit_FunctionDef

    def visit_Raise(self, node):
        exc = node.exc
        if isinstance(exc, ast.Call) and exc.args:
            parts = literal_parts(exc.args[0])
            if any(p.strip() for p in parts):
                self.messages.append({"where": self.where(), "kind": "raise", "class": ast.unparse(exc.func),
                                      "parts": parts})
        self.generic_visit(node)

    def visit_Return(self, node):
        if self.scope[-1] in ("__repr__", "__str__") and node.value is not None:
            parts = literal_parts(node.value)
            if any(p.strip() for p in parts):
                self.messages.append({"where": self.where(), "kind": "repr", "parts": parts})
        self.generic_visit(node)

    def visit_Call(self, node):
        func = ast.unparse(node.func)
        if func in ("print", "warnings.warn") and node.args:
            parts = literal_parts(node.args[0])
            if any(p.strip() for p in parts):
                self.messages.append({"where": self.where(), "kind": func, "parts": parts})
        self.generic_visit(node)


def module_names(tree: ast.Module) -> list:
    for stmt in tree.body:
        if isinstance(stmt, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in stmt.targets):
            return list(ast.literal_eval(stmt.value))
    names = []
    for stmt in tree.body:
        if isinstance(stmt, (ast.FunctionDef, ast.ClassDef)) and not stmt.name.startswith("_"):
            names.append(stmt.name)
        elif isinstance(stmt, ast.ImportFrom) and stmt.level > 0:
            names += [a.asname or a.name for a in stmt.names if not (a.asname or a.name).startswith("_")]
    return names


def main(root: str) -> None:
    base = Path(root)
    surface = {"source": "pyvr 0.4.1", "modules": {}, "callables": {}, "classes": {}, "messages": []}
    for path in sorted((base / "pyvr").rglob("*.py")):
        rel = path.relative_to(base).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        name = ".".join(parts)
        tree = ast.parse(path.read_text())
        surface["modules"][name] = module_names(tree)
        visitor = Module(name)
        visitor.visit(tree)
        surface["callables"].update(visitor.callables)
        surface["classes"].update(visitor.classes)
        surface["messages"] += visitor.messages
    json.dump(surface, sys.stdout, indent=1, sort_keys=True)
    sys.stdout.write("\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
