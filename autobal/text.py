"""Text from inputs on its way to a person (terminal, report): printable and of a sane length.

A scene key, a ``--set`` value, a title or a file name can hold anything: ANSI/OSC escape sequences
(which retitle, clear or recolour a terminal), other control characters, or 200 kB of text.
:func:`clean` is the one place such text is made safe to show.
"""

from __future__ import annotations

import re

LIMIT = 200  # characters of one piece of input text shown in a message

# ESC [ ... final (CSI), ESC ] ... BEL or ESC \ (OSC), ESC P/X/^/_ ... ESC \ (DCS, SOS, PM, APC),
# ESC and one character; and the same introduced by the 8-bit C1 codes (CSI 0x9b, OSC 0x9d, ...)
_ESCAPES = re.compile(r"(?:\x1b\[|\x9b)[0-?]*[ -/]*[@-~]?"
                      r"|(?:\x1b[\]PX^_]|[\x90\x98\x9d\x9e\x9f])[^\x07\x1b\x9c]*(?:\x07|\x1b\\|\x9c)?"
                      r"|\x1b[ -~]?")
_CONTROLS = re.compile(r"[\x00-\x1f\x7f-\x9f]")


def clean(text: object, limit: int | None = LIMIT) -> str:
    """``text`` as one printable line: escape sequences removed, other control characters (newlines
    and tabs included) shown as a space, and cut in the middle to ``limit`` characters with an ellipsis.

    Parameters
    ----------
    text : object
        Anything; ``str(text)`` is shown.
    limit : int or None
        The longest result, characters; None: no cut.

    Returns
    -------
    str
    """
    out = _CONTROLS.sub(" ", _ESCAPES.sub("", str(text)))
    if limit is not None and len(out) > limit:
        head = (limit - 1) * 2 // 3
        out = out[:head] + "…" + out[len(out) - (limit - 1 - head):]
    return out


def clean_lines(text: object) -> str:
    """``text`` with its lines kept and each line cleaned (no cut): for the summaries the CLI prints."""
    return "\n".join(clean(line, None) for line in str(text).split("\n"))
