"""The compiled extension; its public names are re-exported (and typed) by pbd/__init__.pyi."""

from typing import Any

def __getattr__(name: str) -> Any: ...
