"""Host memory checks made before large allocations: a request that cannot
fit raises MemoryError naming what it was for and how much it needed,
instead of the process being killed (or aborting) half way through."""

from typing import Optional

GiB = float(1 << 30)


def _meminfo_available() -> Optional[int]:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _address_space_left() -> Optional[int]:
    """What an address-space limit (ulimit -v, prlimit --as) leaves."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    except (ImportError, OSError, ValueError):
        return None
    if soft == resource.RLIM_INFINITY:
        return None
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmSize:"):
                    return soft - int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return soft


def available_bytes() -> Optional[int]:
    """Bytes this process can still allocate, or None when unknown."""
    known = [b for b in (_meminfo_available(), _address_space_left()) if b is not None]
    return min(known) if known else None


def check_fits(what: str, nbytes: float, advice: str = "") -> None:
    """MemoryError if ``nbytes`` more cannot be allocated now."""
    left = available_bytes()
    if left is not None and nbytes > left:
        raise MemoryError(
            f"{what} needs about {nbytes / GiB:.3g} GiB of memory but about {max(left, 0) / GiB:.3g} GiB is "
            f"available{'; ' + advice if advice else ''}"
        )
