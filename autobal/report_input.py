"""What ``autobal report`` reads from an output folder, read defensively.

An output folder can be damaged or tampered with: results.json truncated, not UTF-8, a list, nested
200,000 deep, a folder, a named pipe; its ``files`` list naming ``../secret.png``, an absolute path
or a symbolic link out of the folder.  Each status file is read here as a regular file of bounded size
(opened without blocking, so a named pipe is refused, not waited on) and parsed to a JSON object, or
refused with a one-line :class:`~autobal.errors.ScenarioError`; a figure is embedded only when it is a
regular file inside the folder, and the names refused are given back to be reported.
"""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

from autobal.errors import ScenarioError
from autobal.text import clean

MAX_JSON_BYTES = 256 * 2**20  # results.json of the largest shipped study is a few MB
MAX_FIGURE_BYTES = 64 * 2**20


def read_regular(path: Path, limit: int) -> bytes:
    """The bytes of ``path`` if it is a regular file of at most ``limit`` bytes; ScenarioError (one line)
    otherwise.  Opened non-blocking and checked on the open file, so a named pipe or a device is never
    read."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as exc:
        raise ScenarioError(f"{clean(path)}: cannot be read ({exc.strerror})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            kind = "a folder" if stat.S_ISDIR(info.st_mode) else "not a regular file"
            raise ScenarioError(f"{clean(path)}: {kind}, not a file autobal wrote")
        if info.st_size > limit:
            raise ScenarioError(f"{clean(path)}: {info.st_size} bytes, more than the {limit} bytes read")
        with os.fdopen(fd, "rb", closefd=False) as fh:
            data = fh.read(limit + 1)
        if len(data) > limit:
            raise ScenarioError(f"{clean(path)}: more than the {limit} bytes read")
        return data
    except OSError as exc:
        raise ScenarioError(f"{clean(path)}: cannot be read ({exc.strerror})") from None
    finally:
        os.close(fd)


def read_json(path: Path) -> dict:
    """The JSON object in ``path`` (results.json or a status file), its strings :func:`printable`;
    ScenarioError with one line when it is not a regular file, not UTF-8, not JSON, nested too deeply or
    not an object."""
    raw = read_regular(path, MAX_JSON_BYTES)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{clean(path)}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start})") \
            from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ScenarioError(f"{clean(path)}: not valid JSON ({exc.msg}: line {exc.lineno}, column {exc.colno}); "
                            f"truncated or damaged?") from None
    except RecursionError:
        raise ScenarioError(f"{clean(path)}: nested too deeply to be a file autobal wrote") from None
    if not isinstance(data, dict):
        raise ScenarioError(f"{clean(path)}: a JSON {type(data).__name__}, not the object autobal writes")
    try:
        return printable(data)
    except RecursionError:
        raise ScenarioError(f"{clean(path)}: nested too deeply to be a file autobal wrote") from None


def printable(data):
    """``data`` (parsed JSON) with every string stripped of control characters and escape sequences
    (:func:`autobal.text.clean`, not cut): what the page shows of it is text, never a terminal command."""
    if isinstance(data, str):
        return clean(data, None)
    if isinstance(data, list):
        return [printable(v) for v in data]
    if isinstance(data, dict):
        return {printable(k): printable(v) for k, v in data.items()}
    return data


def folder_of(path: str | Path) -> Path:
    """``path`` if it is a folder that can be searched; ScenarioError (one line) otherwise."""
    folder = Path(path)
    try:
        info = folder.stat()
    except OSError as exc:
        raise ScenarioError(f"{clean(path)}: cannot be read ({exc.strerror})") from None
    if not stat.S_ISDIR(info.st_mode):
        raise ScenarioError(f"{clean(path)}: not a folder; give an output folder of 'autobal run'")
    return folder


def present(folder: Path, name: str) -> bool:
    """Whether ``folder/name`` exists (as anything: read_json says what is wrong with it)."""
    try:
        os.lstat(folder / name)
        return True
    except OSError:
        return False


def figure(folder: Path, name: object) -> tuple[Path | None, bool]:
    """(``folder/name`` if ``name`` is a string naming a regular file inside ``folder`` after symbolic
    links are resolved, else None; whether ``name`` points outside the folder)."""
    if not isinstance(name, str) or not name or "\0" in name:
        return None, False
    try:
        root = folder.resolve()
        path = (folder / name).resolve()
        if not path.is_relative_to(root) or path == root:
            return None, True
        return (path if path.is_file() else None), False
    except (OSError, RuntimeError, ValueError):  # a name too long, a symbolic-link loop
        return None, False
