"""File outputs shared by the library and the command lines: checks made before any work, atomic writes.

:func:`check_writable_dir` / :func:`check_output_path` fail at once, in one line naming the directory, when an output
cannot be written: they create and remove a probe file where it will go (``os.access`` says yes to root on a read-only
directory). After an atomic write (:func:`atomic_write_bytes` and the others) ``path`` is either the old file or the
complete new one; a path that is not a regular file (``/dev/stdout``, a FIFO) is written to as a stream.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import secrets
from pathlib import Path
from typing import Any

import yaml


def _open_temp(directory: Path, name: str) -> tuple[int, Path]:
    """A new, empty file ``directory/.name.<random>.tmp`` opened for writing, mode 0o666 less the umask."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
    while True:
        tmp = directory / f".{name}.{secrets.token_hex(4)}.tmp"
        try:
            return os.open(tmp, flags, 0o666), tmp
        except FileExistsError:
            continue


def _reason(exc: OSError) -> str:
    return (exc.strerror or type(exc).__name__).lower()


def check_writable_dir(directory: str | Path) -> Path:
    """``directory`` (existing or to be created) can receive files; otherwise a one-line ``OSError`` naming it."""
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise NotADirectoryError(f"{d}: exists and is not a directory")
    existing = d
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise NotADirectoryError(f"{existing}: is a file, not a directory")
    try:
        fd, probe = _open_temp(existing, "write-check")
        os.close(fd)
        probe.unlink()
    except OSError as exc:
        where = f"{d}: not writable" if existing == d else f"{d}: cannot be created, {existing} is not writable"
        raise PermissionError(f"{where} ({_reason(exc)})") from None
    return d


def check_output_path(path: str | Path) -> Path:
    """Fail early, with a clear message, if the file ``path`` cannot be written."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{p}: is a directory, expected a file path")
    if not (p.exists() and not p.is_file()):  # a regular file, not a stream
        check_writable_dir((p.resolve() if p.is_symlink() and p.exists() else p).parent)
        return p
    try:
        with open(p, "ab"):
            pass
    except OSError as exc:
        raise PermissionError(f"{p}: not writable ({_reason(exc)})") from None
    return p


def files_digest(*paths: str | Path) -> str:
    """A short digest (16 hex digits of SHA-256) of the files' bytes, in order: a stored result made from them is
    stale once it changes."""
    h = hashlib.sha256()
    for p in paths:
        h.update(Path(p).read_bytes())
    return h.hexdigest()[:16]


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` so that ``path`` is either the old file or the complete new one (temporary file + rename)."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{p}: is a directory, expected a file path")
    if p.exists() and not p.is_file():  # a device, a pipe: written to, never replaced
        with open(p, "wb") as fh:
            fh.write(data)
        return Path(path)
    p = p.resolve() if p.is_symlink() and p.exists() else p  # the file a symbolic link points to
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = _open_temp(p.parent, p.name)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, p)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return Path(path)


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | Path, data: Any) -> Path:
    return atomic_write_text(path, json.dumps(data, indent=2, sort_keys=False) + "\n")


def atomic_write_yaml(path: str | Path, data: Any) -> Path:
    return atomic_write_text(path, yaml.safe_dump(data, sort_keys=False, allow_unicode=True))


def save_png(fig: Any, path: str | Path, dpi: int = 110) -> Path:
    """A matplotlib figure as a PNG at ``path``, written atomically."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return atomic_write_bytes(path, buf.getvalue())


def read_yaml_mapping(path: str | Path) -> dict:
    """A YAML file that must hold a mapping; errors name the file and what is wrong, in one line."""
    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{p}: not valid YAML ({' '.join(str(exc).split())})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{p}: expected a mapping, got {type(data).__name__}")
    return data
