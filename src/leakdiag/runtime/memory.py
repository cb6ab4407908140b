"""This machine's memory, and sizes in words: for refusing a run that cannot fit before it starts."""

from __future__ import annotations

__all__ = ["memory_bytes", "size_words"]


def memory_bytes() -> int:
    """Physical memory of this machine in bytes.

    Returns
    -------
    int

    Examples
    --------
    >>> memory_bytes() > 2**20
    True
    """
    import os

    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # not POSIX: psutil comes with dask
        import psutil

        return int(psutil.virtual_memory().total)


def size_words(n_bytes: float) -> str:
    """A size in binary units with three significant digits.

    Parameters
    ----------
    n_bytes : float
        Bytes.

    Returns
    -------
    str

    Examples
    --------
    >>> size_words(512), size_words(12.5 * 2**30), size_words(8e12)
    ('512 B', '12.5 GiB', '7.28 TiB')
    """
    units = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"]
    i = 0
    while n_bytes >= 1024 and i < len(units) - 1:
        n_bytes /= 1024
        i += 1
    return f"{n_bytes:.3g} {units[i]}"
