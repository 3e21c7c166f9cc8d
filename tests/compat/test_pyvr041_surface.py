"""pyvr keeps pyvr 0.4.1's public surface: its modules and names, the
signatures of its functions and methods (parameter names, order, kinds and
defaults; new parameters only after them, with defaults), the attributes
its classes have after construction, dataclass defaults, exception
classes, and the text of its messages (errors, printed feedback,
warnings) and reprs.

The record of pyvr 0.4.1 is ``pyvr041_surface.json`` beside this file,
derived from pyvr 0.4.1's source by ``tools/pyvr041_surface.py``. Every
intended difference is listed in ``docs/migration.toml`` under the change
it belongs to; this test fails on a difference that is not listed, and on
a listed one that no longer exists."""

import ast
import builtins
import dataclasses
import importlib
import importlib.util
import inspect
import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
# The tool that made the record; its reading of message literals is reused on pyvr's own source.
_spec = importlib.util.spec_from_file_location("pyvr041_surface", ROOT / "tools" / "pyvr041_surface.py")
SURVEY = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(SURVEY)
SURFACE = json.loads((Path(__file__).parent / "pyvr041_surface.json").read_text())
MIGRATION = ROOT / "docs" / "migration.toml"
# Message fragments shorter than this ("got ", ", ") say nothing on their own.
MIN_FRAGMENT = 8


def listed_differences() -> set:
    changes = tomllib.loads(MIGRATION.read_text())["change"]
    return {key for c in changes for key in c.get("surface", [])}


DROPPED = [k.split(" ", 1)[1] for k in listed_differences() if k.startswith("module ")]


def split_module(qualname: str):
    """(module, attribute path) of a dotted name, the module being the
    longest prefix that pyvr 0.4.1 had as a module."""
    parts = qualname.split(".")
    for i in range(len(parts), 0, -1):
        if ".".join(parts[:i]) in SURFACE["modules"]:
            return ".".join(parts[:i]), parts[i:]
    raise AssertionError(f"no module for {qualname}")


def resolve(qualname: str):
    """Our object for one of pyvr 0.4.1's dotted names; raises LookupError."""
    module, path = split_module(qualname)
    try:
        obj = importlib.import_module(module)
    except ImportError as e:
        raise LookupError(f"module {module}") from e
    for name in path:
        try:
            obj = inspect.getattr_static(obj, name) if inspect.isclass(obj) else getattr(obj, name)
        except AttributeError as e:
            raise LookupError(qualname) from e
    return obj


def default_value(source: str):
    """The value a default's source text gives (dataclass field factories
    included)."""
    def field(default=None, default_factory=None):
        return default_factory() if default_factory is not None else default

    return eval(source, {"np": np, "field": field, "Optional": None})  # noqa: S307 - pyvr 0.4.1's own literals


def same(a, b) -> bool:
    try:
        return bool(np.array_equal(np.asarray(a), np.asarray(b))) if not isinstance(a, str) else a == b
    except Exception:
        return a == b


def _field_defaults(cls) -> dict:
    """A dataclass's field defaults, factories called (the signature shows
    only that a factory exists)."""
    if not dataclasses.is_dataclass(cls):
        return {}
    return {f.name: f.default_factory() for f in dataclasses.fields(cls) if f.default_factory is not dataclasses.MISSING}


def signature_differences(qualname: str, theirs: list, ours, factories: dict = None) -> list:
    """How our signature fails to accept every call pyvr 0.4.1's accepted
    (``factories``: defaults that a dataclass makes per instance)."""
    factories = factories or {}
    try:
        sig = inspect.signature(ours)
    except (TypeError, ValueError):
        return [f"signature {qualname}: not introspectable"]
    ours_params = [p for p in sig.parameters.values() if p.name not in ("self", "cls")]
    theirs = [p for p in theirs if p[0] not in ("self", "cls")]
    out = []
    by_name = {p.name: p for p in ours_params}
    positional = [p for p in ours_params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    their_positional = [p for p in theirs if p[1] in ("POSITIONAL_ONLY", "POSITIONAL_OR_KEYWORD")]
    for name, kind, default in theirs:
        mine = by_name.get(name)
        if kind in ("VAR_POSITIONAL", "VAR_KEYWORD"):
            if not any(p.kind.name == kind for p in ours_params):
                out.append(f"signature {qualname}: no *{name}")
            continue
        if mine is None:
            out.append(f"signature {qualname}: no parameter {name}")
            continue
        if kind == "POSITIONAL_OR_KEYWORD" and mine.kind != mine.POSITIONAL_OR_KEYWORD:
            out.append(f"signature {qualname}: {name} is {mine.kind.name}")
        if kind != "KEYWORD_ONLY":
            j = their_positional.index([name, kind, default])
            if j >= len(positional) or positional[j].name != name:
                out.append(f"signature {qualname}: {name} is not positional argument {j}")
        if default is None and mine.default is not mine.empty:
            continue  # a default where pyvr required the argument: every old call still works
        if default is not None:
            if mine.default is mine.empty:
                out.append(f"signature {qualname}: {name} has no default")
            elif not same(factories.get(name, mine.default), default_value(default)):
                out.append(f"signature {qualname}: {name} defaults to {mine.default!r}, pyvr 0.4.1 to {default}")
    known = {p[0] for p in theirs}
    for p in ours_params:
        if p.name in known or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        if p.default is p.empty:
            out.append(f"signature {qualname}: new parameter {p.name} has no default")
        elif p.kind != p.KEYWORD_ONLY and positional.index(p) < len(their_positional):
            out.append(f"signature {qualname}: new parameter {p.name} comes before pyvr 0.4.1's")
    return out


def module_differences() -> list:
    found = []
    for module, names in SURFACE["modules"].items():
        try:
            mod = importlib.import_module(module)
        except ImportError:
            found.append(f"module {module}")
            continue
        found += [f"name {module}.{n}" for n in names if not hasattr(mod, n)]
    return found


def signature_list() -> list:
    found = []
    for qualname, info in SURFACE["callables"].items():
        try:
            obj = resolve(qualname)
        except LookupError:
            found.append(f"name {qualname}")
            continue
        if info["kind"] == "property":
            if not isinstance(obj, property) and not inspect.isdatadescriptor(obj):
                found.append(f"signature {qualname}: not a property")
            continue
        if isinstance(obj, (classmethod, staticmethod)):
            obj = obj.__func__
        if qualname.endswith(".__init__"):
            owner = resolve(qualname.rsplit(".", 1)[0])
            found += signature_differences(qualname, info["params"], owner, _field_defaults(owner))
        else:
            found += signature_differences(qualname, info["params"], obj)
    return found


def _instances():
    """One instance of each of pyvr 0.4.1's classes whose attributes it
    documents, built the usual way."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pyvr.camera import Camera, CameraController, CameraPath
    from pyvr.interface import matplotlib_interface, widgets
    from pyvr.interface.state import InterfaceState
    from pyvr.lighting import Light
    from pyvr.moderngl_renderer.renderer import ModernGLVolumeRenderer
    from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
    from pyvr.volume import Volume

    fig, axes = plt.subplots(1, 5)
    volume = Volume(data=np.zeros((4, 4, 4), np.float32))
    made = {
        "pyvr.camera.control.CameraController": CameraController(Camera()),
        "pyvr.camera.control.CameraPath": CameraPath([Camera(), Camera.front_view()]),
        "pyvr.interface.matplotlib_interface.InteractiveVolumeRenderer":
            matplotlib_interface.InteractiveVolumeRenderer(volume, width=8, height=8),
        "pyvr.interface.state.InterfaceState": InterfaceState(),
        "pyvr.interface.widgets.ColorSelector": widgets.ColorSelector(axes[0]),
        "pyvr.interface.widgets.FPSCounter": widgets.FPSCounter(),
        "pyvr.interface.widgets.ImageDisplay": widgets.ImageDisplay(axes[1]),
        "pyvr.interface.widgets.OpacityEditor": widgets.OpacityEditor(axes[2]),
        "pyvr.interface.widgets.PresetSelector": widgets.PresetSelector(axes[3]),
        "pyvr.moderngl_renderer.renderer.ModernGLVolumeRenderer": ModernGLVolumeRenderer(8, 8),
        "pyvr.transferfunctions.base.BaseTransferFunction": OpacityTransferFunction.linear(),
        "pyvr.transferfunctions.color.ColorTransferFunction": ColorTransferFunction.grayscale(),
        "pyvr.transferfunctions.opacity.OpacityTransferFunction": OpacityTransferFunction.linear(),
        "pyvr.camera.camera.Camera": Camera(),
        "pyvr.lighting.light.Light": Light(),
        "pyvr.volume.data.Volume": volume,
    }
    plt.close(fig)
    return made


def class_differences() -> list:
    from pyvr.config import RenderConfig

    instances = _instances()
    instances["pyvr.config.RenderConfig"] = RenderConfig()
    found = []
    for qualname, info in SURFACE["classes"].items():
        try:
            cls = resolve(qualname)
        except LookupError:
            found.append(f"name {qualname}")
            continue
        for base in info["bases"]:
            theirs = getattr(builtins, base, None)
            if theirs is None:
                try:
                    theirs = resolve(f"{qualname.rsplit('.', 1)[0]}.{base}")
                except LookupError:
                    theirs = None
            if isinstance(theirs, type) and not issubclass(cls, theirs):
                found.append(f"base {qualname}: not a {base}")
        attributes = info["init_attributes"] + list(info["fields"])
        if not attributes:
            continue
        obj = instances.get(qualname)
        assert obj is not None, f"add an instance of {qualname} to _instances()"
        found += [f"attribute {qualname}.{a}" for a in attributes if not hasattr(obj, a)]
        for name, source in info["fields"].items():
            if source is not None and hasattr(obj, name) and not same(getattr(obj, name), default_value(source)):
                found.append(f"default {qualname}.{name}")
    return found


def _our_messages():
    """Every string pyvr's source can make, as (literal parts, exception
    classes raised with it): Python literals, f-strings and their
    concatenations, and Rust string literals (``{...}`` being values)."""
    messages = []
    for path in (ROOT / "python" / "pyvr").rglob("*.py"):
        tree = ast.parse(path.read_text())
        raised = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call) and node.exc.args:
                raised[id(node.exc.args[0])] = ast.unparse(node.exc.func)
        for node in ast.walk(tree):
            if isinstance(node, (ast.Constant, ast.JoinedStr, ast.BinOp)):
                parts = SURVEY.literal_parts(node)
                if parts:
                    messages.append((parts, raised.get(id(node))))
    for path in (ROOT / "src").rglob("*.rs"):
        for literal in _rust_strings(path.read_text()):
            messages.append((re.split(r"\{[^{}]*\}", literal), None))
    return messages


_RUST_TOKEN = re.compile(r"""
      //[^\n]*                              # line comment
    | /\*.*?\*/                              # block comment
    | r(?P<hashes>\#*)"(?P<raw>.*?)"(?P=hashes)  # raw string
    | b?"(?P<text>(?:[^"\\]|\\.)*)"          # string
    | '(?:[^'\\]|\\.[^']*)'                  # char literal
    """, re.VERBOSE | re.DOTALL)


def _rust_strings(source: str) -> list:
    """The string literals of Rust source (comments and char literals,
    which may hold quotes, skipped); a line continuation joins lines."""
    out = []
    for m in _RUST_TOKEN.finditer(source):
        if m.group("raw") is not None:
            out.append(m.group("raw"))
        elif m.group("text") is not None:
            out.append(re.sub(r"\\\n\s*", "", m.group("text")))
    return out


def _makes(parts: list, text: str) -> bool:
    """Whether a message with these literal parts can contain ``text``: as
    part of one literal, or as a run of its parts with values in the gaps
    (and around the run, where values go)."""
    if any(text in p for p in parts):
        return True
    if not any(len(p.strip()) >= 4 and p.strip() in text for p in parts):
        return False  # no literal of this message in the text: no run of it can make the text
    n = len(parts)
    for i in range(n):
        for j in range(i + 1, n):
            run = parts[i:j + 1]
            if sum(len(p.strip()) for p in run) < MIN_FRAGMENT:
                continue
            pattern = ("(.*)" if i > 0 else "") + "(.*)".join(re.escape(p) for p in run) + ("(.*)" if j < n - 1 else "")
            if re.fullmatch(pattern, text, re.DOTALL):
                return True
    return False


# Raised inside the readers and turned into this before it reaches the user.
_RAISED_AS = {"Malformed": "FileFormatError"}


def _exception_class(name: str):
    name = _RAISED_AS.get(name, name)
    if hasattr(builtins, name):
        return getattr(builtins, name)
    for module in SURFACE["modules"]:
        try:
            mod = importlib.import_module(module)
        except ImportError:
            continue
        if isinstance(getattr(mod, name.split(".")[-1], None), type):
            return getattr(mod, name.split(".")[-1])
    return None


def message_differences() -> list:
    messages = _our_messages()
    found = []
    for m in SURFACE["messages"]:
        for part in m["parts"]:
            text = part.strip()
            if len(text) < MIN_FRAGMENT:
                continue
            makers = [cls for parts, cls in messages if _makes(parts, text)]
            if not makers:
                found.append(f"message {m['where']}: {text}")
                continue
            classes = {c for c in makers if c is not None}
            if m["kind"] == "raise" and classes:
                theirs = _exception_class(m["class"])
                ours = [_exception_class(c) for c in classes]
                if theirs is not None and not any(isinstance(c, type) and issubclass(c, theirs) for c in ours):
                    found.append(f"class {m['where']}: {text} ({', '.join(sorted(classes))} is not a {m['class']})")
    return found


def _in_dropped_module(key: str) -> bool:
    """Whether a difference lies in a module listed as gone ("module X"):
    its names, signatures and messages go with it."""
    path = key.split(" ", 1)[1].split(":", 1)[0]
    return any(path == m or path.startswith(m + ".") for m in DROPPED)


def check(found: list) -> None:
    listed = listed_differences()
    unlisted = sorted(k for k in set(found) - listed if not _in_dropped_module(k))
    assert not unlisted, (
        "differences from pyvr 0.4.1 not listed in docs/migration.toml (fix them, or list each under the "
        "change it belongs to):\n  " + "\n  ".join(unlisted))


def test_modules_and_names():
    check(module_differences())


def test_signatures():
    check(signature_list())


def test_attributes_defaults_and_exception_classes(capsys):
    check(class_differences())
    capsys.readouterr()  # the interface's "Loading histogram..."


def test_messages():
    check(message_differences())


def test_every_listed_difference_still_exists(capsys):
    found = set(module_differences() + signature_list() + class_differences() + message_differences())
    capsys.readouterr()
    stale = sorted(listed_differences() - found)
    assert not stale, "listed in docs/migration.toml but no longer different:\n  " + "\n  ".join(stale)


def test_migration_tables_are_generated_from_the_toml():
    import subprocess
    import sys

    run = subprocess.run([sys.executable, str(ROOT / "tools" / "migration_table.py"), "--check"], capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stdout


def test_every_listed_difference_is_one_this_test_reports():
    prefixes = ("module ", "name ", "signature ", "base ", "attribute ", "default ", "message ", "class ")
    bad = [k for k in listed_differences() if not k.startswith(prefixes)]
    assert not bad, bad


@pytest.mark.parametrize("key", ["was", "now", "why"])
def test_every_change_says_what_was_what_is_and_why(key):
    for change in tomllib.loads(MIGRATION.read_text())["change"]:
        assert change.get(key, "").strip(), change
