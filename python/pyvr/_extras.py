"""Optional libraries: imported where a reader needs them, with an error
that names the extra to install when one is missing."""

import importlib


def require(module: str, extra: str, what: str):
    """Import ``module`` or raise ImportError naming ``pip install pyvr-rs[extra]``."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise ImportError(
            f"{what} needs the optional package '{module.split('.')[0]}': "
            f"pip install 'pyvr-rs[{extra}]'"
        ) from e
