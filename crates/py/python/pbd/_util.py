"""Helpers shared by the package's modules: reports, progress, options."""

from __future__ import annotations

import os
import sys
from typing import Any, Callable, Optional, Union

ProgressCallback = Callable[[str, str, Optional[int]], None]


class Report(dict):
    """The report of a pipeline: a dict (exactly what ``pbd <command> --json`` prints) whose ``str()``
    is the human summary the command prints. ``warnings`` lists what was reported on the way."""

    def __init__(self, data: dict, text: str, warnings: list):
        super().__init__(data)
        self.text = text
        self.warnings = list(warnings)

    def __str__(self) -> str:
        return self.text


class TextProgress:
    """A progress callable for the pipelines: a bar on stderr (tqdm when installed, else lines).

    Any callable ``f(event, text, value)`` works as ``progress=``; events are ``phase`` (text = name,
    value = total or None), ``advance`` (value = n), ``position``, ``message``, ``warn``, ``finish``.
    Raising from it stops the pipeline at its next safe point and re-raises the exception.
    """

    def __init__(self, file=None):
        self.file = file or sys.stderr
        self.bar = None
        self.name = ""

    def __call__(self, event: str, text: str, value: Optional[int]) -> None:
        if event == "phase":
            self._close()
            self.name = text
            try:
                from tqdm.auto import tqdm  # type: ignore

                self.bar = tqdm(total=value, desc=text, file=self.file)
            except ImportError:
                self.bar = None
                print(f"[{text}] start" + (f" ({value})" if value else ""), file=self.file)
        elif event == "advance" and self.bar is not None:
            self.bar.update(value or 0)
        elif event == "position" and self.bar is not None:
            self.bar.n = value or 0
            self.bar.refresh()
        elif event in ("message", "warn"):
            prefix = "warning: " if event == "warn" else ""
            if self.bar is not None:
                self.bar.write(prefix + text, file=self.file)
            else:
                print(prefix + text, file=self.file)
        elif event == "finish":
            self._close()

    def _close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _progress(progress: Union[bool, ProgressCallback, None]) -> Optional[ProgressCallback]:
    if progress is True:
        return TextProgress()
    if progress is False or progress is None:
        return None
    return progress


def _options(**kw: Any) -> dict:
    return {k: (os.fspath(v) if isinstance(v, os.PathLike) else v) for k, v in kw.items() if v is not None}


def _report(out) -> Report:
    data, text, warnings = out
    return Report(data, text, warnings)
