"""Every public name has a docstring: the documentation site's API reference
(docs/api.rst) is generated from them, so a name without one would be listed
there with nothing to say."""

import importlib
import inspect

import pytest

# The modules docs/api.rst documents.
MODULES = ["renderer", "config", "camera", "lighting", "transferfunctions", "volume", "dataloaders", "datasets",
           "accuracy", "bricks", "distributed", "animation", "interaction", "notebook", "interface", "refinement"]


def public_names(module):
    names = getattr(module, "__all__", None)
    if names is None:
        names = [n for n, v in vars(module).items()
                 if not n.startswith("_") and getattr(v, "__module__", None) == module.__name__]
    return names


def undocumented(module):
    missing = []
    for name in public_names(module):
        obj = getattr(module, name)
        if not (inspect.isclass(obj) or inspect.isroutine(obj)):
            continue
        if not (obj.__doc__ or "").strip():
            missing.append(name)
        if inspect.isclass(obj):
            for attr, value in vars(obj).items():
                if attr.startswith("_"):
                    continue
                if isinstance(value, (staticmethod, classmethod)):
                    value = value.__func__
                if not (inspect.isroutine(value) or isinstance(value, property)):
                    continue
                if not (getattr(value, "__doc__", None) or "").strip():
                    missing.append(f"{name}.{attr}")
    return missing


@pytest.mark.parametrize("name", MODULES)
def test_every_public_name_has_a_docstring(name):
    module = importlib.import_module(f"pyvr.{name}")
    assert (module.__doc__ or "").strip(), f"pyvr.{name} has no module docstring"
    assert undocumented(module) == []
