"""Small helpers for command-line outputs: atomic writes and clear path errors."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any


def check_output_path(path: str | Path) -> Path:
    """Fail early, with a clear message, if ``path`` cannot be written."""
    p = Path(path)
    if p.exists() and p.is_dir():
        raise IsADirectoryError(f"{p}: is a directory, expected a file path")
    parent = p.parent if str(p.parent) else Path(".")
    if parent.exists() and not parent.is_dir():
        raise NotADirectoryError(f"{parent}: is a file, not a directory")
    return p


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` so that ``path`` is either the old file or the complete new one."""
    p = check_output_path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=f".{p.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, p)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return p


def atomic_write_json(path: str | Path, data: Any) -> Path:
    return atomic_write_text(path, json.dumps(data, indent=2, sort_keys=False) + "\n")


def read_yaml_mapping(path: str | Path) -> dict:
    """A YAML file that must hold a mapping; errors name the file and what is wrong, in one line."""
    import yaml

    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{p}: not valid YAML ({' '.join(str(exc).split())})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{p}: expected a mapping, got {type(data).__name__}")
    return data
