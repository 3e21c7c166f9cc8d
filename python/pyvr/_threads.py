"""One thread at a time in a renderer's engine, and its lock made anew in
a child made by fork()."""

import functools
import os
import threading
import weakref


def _serialised(method):
    """One thread at a time in the engine: it renders with the GIL released,
    and a second call meanwhile would find it busy ("Already borrowed").
    Other threads wait their turn instead."""
    @functools.wraps(method)
    def call(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)

    return call


_RENDERERS: "weakref.WeakSet" = weakref.WeakSet()


def _after_fork_in_child() -> None:
    # A lock held by a parent thread at the fork would stay held for ever.
    for r in list(_RENDERERS):
        r._lock = threading.RLock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)
