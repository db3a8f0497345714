"""Text from outside is escaped (app.ui.text): the fast escaping equals a per-character one.

The panels escape every text from outside on every redraw, so :mod:`app.ui.text` escapes a
line with one ``str.translate`` and keeps a printable line in one pass. The reference
below is the obvious definition, one character at a time; both must give the same text
for every input.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from app.ui import text
from app.ui.text import markdown_text, one_line

ENTITIES = {"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#x27;"}
MARKDOWN = "\\`*_[]|~"


def slow_one_line(value: object) -> str:
    """One line: breaks become spaces, every other non-printable character but tab goes."""
    joined = text._BREAKS.sub(" ", str(value))
    return "".join(c for c in joined if c.isprintable() or c == "\t")


def slow_escape(c: str) -> str:
    """One character as markdown shows it literally."""
    if c in ENTITIES:
        return ENTITIES[c]
    return "\\" + c if c in MARKDOWN else c


def slow_markdown(value: object, lines: bool = False) -> str:
    """:func:`markdown_text` with the escaping done one character at a time."""
    cut = text._cut(str(value), text.BLOCK_CHARS if lines else text.LINE_CHARS)
    parts = cut.splitlines() if lines else [slow_one_line(cut)]
    out = []
    for part in parts:
        escaped = "".join(slow_escape(c) for c in slow_one_line(part))
        escaped = text._AUTOLINK.sub(text._SPLIT, escaped)
        block = text._LINE_START.match(escaped)
        if block is not None:
            indent, mark = block.groups()
            if mark[0].isdigit():
                escaped = escaped[: block.end()] + "\\" + escaped[block.end() :]
            else:
                escaped = indent + "\\" + escaped[len(indent) :]
        out.append(escaped)
    return "  \n".join(out)


# Characters that matter (marks, entities, breaks, controls, tab, digits, '#', '@', '.'),
# mixed with any text at all.
TRICKY = st.sampled_from(
    list(MARKDOWN + "&<>\"'\t\r\n\x00\x0b\x0c\x85\u2028\u2029\u200b#-+=1.)@/w ")
)
TEXTS = st.lists(st.one_of(TRICKY, st.characters()), max_size=80).map("".join)


@settings(max_examples=400, deadline=None)
@given(TEXTS, st.booleans())
def test_markdown_text_equals_escaping_one_character_at_a_time(
    value: str, lines: bool
) -> None:
    assert markdown_text(value, lines=lines) == slow_markdown(value, lines)


@settings(max_examples=400, deadline=None)
@given(TEXTS)
def test_one_line_equals_filtering_one_character_at_a_time(value: str) -> None:
    assert one_line(value) == slow_one_line(value)


def test_every_mark_and_entity_is_escaped_and_controls_go() -> None:
    assert markdown_text(MARKDOWN) == "".join("\\" + c for c in MARKDOWN)
    assert markdown_text("&<>\"'") == "&amp;&lt;&gt;&quot;&#x27;"
    assert one_line("a\tb\x00c\x1bd\u200be") == "a\tbcde"  # tab stays, controls go
    assert one_line("plain text") == "plain text"
    assert markdown_text("x" * 600).endswith("...") and "\\" not in markdown_text("x")
