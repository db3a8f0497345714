r"""Text from outside shown as text: never as markup.

viser renders a markdown element's raw HTML (scripts included) and an HTML element as
is. A scene's name and description, a file's name, an error that quotes a field of an
uploaded file, a value a browser sent: all of it can be written by a hostile student,
and all of it reaches the panels of other browsers, the presenter's among them. Every
such text goes through :func:`markdown_text` (inside markdown) or :func:`html_text`
(inside HTML) before it is put in a panel; the markup around it is the app's own.

Examples
--------
>>> markdown_text('<iframe srcdoc="<script>alert(1)</script>">')
'&lt;iframe srcdoc=&quot;&lt;script&gt;alert(1)&lt;/script&gt;&quot;&gt;'
>>> markdown_text("[click](javascript:alert(1)) **bold**")
'\\[click\\](javascript:alert(1)) \\*\\*bold\\*\\*'
>>> markdown_text("# title\n1. first\n- item | cell", lines=True)
'\\# title  \n1\\. first  \n\\- item \\| cell'
>>> markdown_text("see http://example.org or www.example.org, mail a@b.org")
'see http:<!-- -->//example.org or www<!-- -->.example.org, mail a<!-- -->@b.org'
>>> html_text("<b>O_1</b> & 'x'")
'&lt;b&gt;O_1&lt;/b&gt; &amp; &#x27;x&#x27;'
"""

from __future__ import annotations

__all__ = ["html_text", "markdown_text", "one_line"]

import html
import re

_ENTITIES = {"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#x27;"}
# The marks that make inline markdown (code, emphasis, links and images, tables,
# strike-through) are escaped with a backslash wherever they stand; '&' '<' '>' '"' "'"
# become entities (no HTML, no autolink); without '[' and ']' no link or image can form.
_MARKDOWN = frozenset("\\`*_[]|~")
_ESCAPES = str.maketrans({**{c: "\\" + c for c in _MARKDOWN}, **_ENTITIES})
# GitHub's autolinks turn "http://...", "www...." and "a@b.c" into links, found in the
# text after escapes and entities are read (neither stops them), and show the entities
# inside them as written: an empty comment splits the text where one would begin.
_AUTOLINK = re.compile(r"(?i)(?=//)|(?<=\bwww)(?=&#46;|\.)|(?=@)")
_SPLIT = "<!-- -->"
# What makes a block only at the start of a line: a heading, a list, a rule.
_LINE_START = re.compile(r"^(\s*)([#+=-]|\d+(?=[.)]))")
_BREAKS = re.compile(r"[\r\n\u2028\u2029\x0b\x0c\x85]+")


def one_line(text: object) -> str:
    r"""Return ``text`` as one line: line breaks become spaces, other controls go.

    Examples
    --------
    >>> one_line("a\r\nb\x00c")
    'a bc'
    """
    joined = _BREAKS.sub(" ", str(text))
    if joined.isprintable():  # the usual case, decided in one pass
        return joined
    return "".join(c for c in joined if c.isprintable() or c == "\t")


LINE_CHARS = 500
"""Most characters of a one-line text a panel shows (the rest is cut, marked '...')."""
BLOCK_CHARS = 4000
"""Most characters of a text of several lines a panel shows: a browser takes seconds
to lay out a paragraph of a hundred thousand characters, and every follower's does."""


def markdown_text(text: object, *, lines: bool = False) -> str:
    """Return ``text`` escaped to show literally inside markdown (and its raw HTML).

    The text is cut at :data:`LINE_CHARS` (one line) or :data:`BLOCK_CHARS` (``lines``).

    Parameters
    ----------
    text
        Any text from outside (it is made a ``str`` first).
    lines
        Keep line breaks (as markdown hard breaks); otherwise the text is one line.

    Examples
    --------
    >>> len(markdown_text("a" * 10_000))
    503
    """
    text = _cut(str(text), BLOCK_CHARS if lines else LINE_CHARS)
    parts = text.splitlines() if lines else [one_line(text)]
    escaped = (_escape_line(one_line(part)) for part in parts)
    return "  \n".join(escaped)


def html_text(text: object) -> str:
    """Return ``text`` escaped to show literally inside HTML (quotes included).

    The text is cut at :data:`BLOCK_CHARS`.
    """
    return html.escape(_cut(str(text), BLOCK_CHARS), quote=True)


def _cut(text: str, most: int) -> str:
    return text if len(text) <= most else text[:most] + "..."


def _escape_line(line: str) -> str:
    escaped = line.translate(_ESCAPES)
    escaped = _AUTOLINK.sub(_SPLIT, escaped)
    block = _LINE_START.match(escaped)
    if block is None:
        return escaped
    indent, mark = block.groups()
    if mark[0].isdigit():  # "1." or "1)": escape what follows the number
        end = block.end()
        return escaped[:end] + "\\" + escaped[end:]
    return indent + "\\" + escaped[len(indent) :]
