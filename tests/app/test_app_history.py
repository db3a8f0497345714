"""The undo history as a pure value: undo/redo, gestures, redo cleared by a new edit."""

from __future__ import annotations

from app.session.history import MERGE_WINDOW_S, Entry, History


def edits(history: History, states: list[str], key=None, phased=False, dt=0.1):
    """Record edits leaving ``states[0]``, ``states[1]``, ... behind, ``dt`` s apart."""
    for k, state in enumerate(states):
        history = history.record(Entry(state), key, now=k * dt, phased=phased)
    return history


def step(result):
    """The (history, entry) of an undo or redo that had something to do."""
    assert result is not None
    return result


def test_undo_and_redo_walk_back_and_forth():
    h = edits(History(), ["a", "b"])  # a -> b -> c (current)
    h, back = step(h.undo(Entry("c")))
    assert back == Entry("b") and h.can_redo
    h, back = step(h.undo(Entry("b")))
    assert back == Entry("a") and not h.can_undo
    assert h.undo(Entry("a")) is None  # nothing to undo: the caller says so
    h, forward = step(h.redo(Entry("a")))
    assert forward == Entry("b")
    h, forward = step(h.redo(Entry("b")))
    assert forward == Entry("c") and not h.can_redo
    assert h.redo(Entry("c")) is None


def test_the_scenario_travels_with_the_scene():
    h = History().record(Entry("old", "01_two_convex"), key=None, now=0.0)
    _, back = step(h.undo(Entry("new", "")))
    assert back == Entry("old", "01_two_convex")


def test_a_new_edit_clears_redo():
    h = edits(History(), ["a", "b"])
    h, _ = step(h.undo(Entry("c")))
    assert h.can_redo
    h = h.record(Entry("b"), key=None, now=5.0)
    assert not h.can_redo


def test_history_values_are_never_changed_in_place():
    h0 = History()
    h1 = h0.record(Entry("a"), key=None, now=0.0)
    assert h0 == History() and h1 is not h0
    h2, _ = step(h1.undo(Entry("b")))
    assert h1.undo_stack == (Entry("a"),) and h2.undo_stack == ()


def test_unphased_edits_with_one_key_merge_within_the_window():
    slider = ("robot", "radius")
    h = edits(History(), ["r0", "r1", "r2", "r3"], key=slider, dt=0.2)
    assert len(h.undo_stack) == 1 and h.undo_stack[0] == Entry("r0")
    # After a pause longer than the window the same slider opens a new step.
    h = h.record(Entry("r4"), key=slider, now=0.6 + MERGE_WINDOW_S + 0.01)
    assert [e.scene for e in h.undo_stack] == ["r0", "r4"]


def test_different_keys_and_keyless_edits_do_not_merge():
    h = History().record(Entry("a"), key=("radius",), now=0.0)
    h = h.record(Entry("b"), key=("sensor_range",), now=0.1)
    h = h.record(Entry("c"), key=None, now=0.2)
    h = h.record(Entry("d"), key=None, now=0.3)
    assert [e.scene for e in h.undo_stack] == ["a", "b", "c", "d"]


def test_a_phased_gesture_merges_until_closed_however_slow():
    goal = ("goal",)
    h = History().closed()  # a drag's start closes any open step
    h = edits(h, ["g0", "g1", "g2"], key=goal, phased=True, dt=10 * MERGE_WINDOW_S)
    assert [e.scene for e in h.undo_stack] == ["g0"]
    h = h.closed()  # the drag's end
    h = h.record(Entry("g3"), key=goal, now=100.0, phased=True)  # a second drag
    assert [e.scene for e in h.undo_stack] == ["g0", "g3"]


def test_undo_closes_the_open_gesture():
    slider = ("radius",)
    h = History().record(Entry("a"), key=slider, now=0.0)
    h, _ = step(h.undo(Entry("b")))
    h = h.record(Entry("a"), key=slider, now=0.1)  # same slider right after: new step
    assert h.gesture == slider and len(h.undo_stack) == 1 and not h.can_redo
