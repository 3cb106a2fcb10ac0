"""Progress bars for loops that take more than a couple of seconds (labs, long commands).

:func:`progress` wraps an iterable in tqdm's automatic bar: in JupyterLab the notebook widget,
in a terminal the text bar. With ``KIT_FAST=1`` (CI, nbval, the recorded outputs of the
solutions) no bar is drawn, so a notebook's recorded outputs do not depend on timing.

>>> sum(progress(range(4), desc="counting"))   # a bar on stderr unless KIT_FAST=1
6
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from typing import TypeVar

__all__ = ["progress", "progress_enabled"]

T = TypeVar("T")


def progress_enabled() -> bool:
    """False under ``KIT_FAST=1``: outputs recorded for comparison stay free of bars."""
    return os.environ.get("KIT_FAST") != "1"


def progress(iterable: Iterable[T], desc: str = "", total: int | None = None,
             unit: str = "it") -> Iterator[T]:
    """``iterable`` with a progress bar (``tqdm.auto``), or as it is under ``KIT_FAST=1``."""
    if not progress_enabled():
        yield from iterable
        return
    from tqdm.auto import tqdm

    yield from tqdm(iterable, desc=desc, total=total, unit=unit, leave=False)
