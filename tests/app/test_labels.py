"""The label placer (app.ui.labels): no two boxes overlap, none covers a marker, all inside.

The properties check every result against slow references that share no code with the
placer: overlap as a positive shapely intersection area, "inside" against the picture
rectangle, and placement again from scratch (the placer is a pure function).
"""

from __future__ import annotations

import itertools
import math

import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from app.ui import labels
from app.ui.labels import Box, LabelRequest, PlacedLabel, label_size, place_labels

PICTURE = (640.0, 400.0)


def area_overlap(a: Box, b: Box) -> float:
    """Reference: the area two boxes share, by shapely."""
    return (
        shapely.box(a.x0, a.y0, a.x1, a.y1)
        .intersection(shapely.box(b.x0, b.y0, b.x1, b.y1))
        .area
    )


def check(placement, markers, reserved, picture) -> None:
    boxes = [p.box for p in placement.placed]
    for a, b in itertools.combinations(boxes, 2):
        assert area_overlap(a, b) <= 1e-9, (a, b)
    for box in boxes:
        for other in [*markers, *reserved]:
            assert area_overlap(box, other) <= 1e-9, (box, other)
        assert shapely.box(0, 0, *picture).covers(
            shapely.box(box.x0, box.y0, box.x1, box.y1)
        )


texts = st.sampled_from(["1", "12", "H1", "D2", "M3", "L10", "start", "goal"])
points = st.tuples(
    st.floats(-20, PICTURE[0] + 20, allow_nan=False),
    st.floats(-20, PICTURE[1] + 20, allow_nan=False),
)
requests = st.lists(
    st.builds(
        LabelRequest,
        text=texts,
        anchor=points,
        centred=st.booleans(),
        clearance=st.floats(0, 30),
    ),
    max_size=25,
)
boxes = st.builds(
    lambda x, y, w, h: Box(x, y, x + w, y + h),
    st.floats(0, PICTURE[0]),
    st.floats(0, PICTURE[1]),
    st.floats(1, 80),
    st.floats(1, 80),
)


@given(requests, st.lists(boxes, max_size=8), st.lists(boxes, max_size=2))
def test_no_box_overlaps_another_a_marker_or_the_reserved_and_all_are_inside(
    asked, markers, reserved
) -> None:
    placement = place_labels(
        asked, font_px=14, picture=PICTURE, markers=markers, reserved=reserved
    )
    check(placement, markers, reserved, PICTURE)
    # Every label is either placed or reported dropped; the placed keep the order asked.
    dropped = {id(r) for r in placement.dropped}
    assert [id(p.request) for p in placement.placed] == [
        id(r) for r in asked if id(r) not in dropped
    ]
    assert len(placement.placed) + len(placement.dropped) == len(asked)
    # Pure: the same question, the same answer.
    assert (
        place_labels(
            asked, font_px=14, picture=PICTURE, markers=markers, reserved=reserved
        )
        == placement
    )


def reference_candidates(request: LabelRequest, size, gap, picture):
    """Reference: the candidate boxes in the placer's documented order, one by one.

    Centred on the anchor (``centred`` only), beside it in the eight directions, on
    the rings (16 angles ``2 pi k / 16 - pi / 4`` each), then the picture's grid.
    """
    anchor = request.anchor
    if request.centred:
        yield labels._centred(anchor, size)
    for d in labels._DIRECTIONS:
        yield labels._beside(anchor, size, d, gap)
    step = max(size[1], gap)
    for ring in range(1, labels._RINGS + 1):
        radius = gap + ring * step
        for k in range(labels._RING_DIRECTIONS):
            a = 2 * math.pi * k / labels._RING_DIRECTIONS - math.pi / 4
            centre = (
                anchor[0] + math.cos(a) * (radius + size[0] / 2),
                anchor[1] + math.sin(a) * (radius + size[1] / 2),
            )
            yield labels._centred(centre, size)
    yield from labels._scan(anchor, size, picture)


def reference_place(asked, *, font_px, picture, markers=(), reserved=()):
    """Reference: each label takes the first candidate inside the picture that overlaps
    no box taken, tried one at a time with :meth:`Box.inside` and :meth:`Box.overlaps`."""
    taken, placed, dropped = [*markers, *reserved], [], []
    for request in asked:
        size = label_size(request.text, font_px)
        gap = max(font_px / 2, request.clearance)
        box = next(
            (
                b
                for b in reference_candidates(request, size, gap, picture)
                if b.inside(*picture) and not any(b.overlaps(t) for t in taken)
            ),
            None,
        )
        if box is None:
            dropped.append(request)
            continue
        taken.append(box)
        placed.append(PlacedLabel(request, box, labels._leader(request, box, gap)))
    return placed, dropped


@given(requests, st.lists(boxes, max_size=40), st.lists(boxes, max_size=2))
def test_the_placer_takes_the_first_free_candidate_as_a_plain_loop_does(
    asked, markers, reserved
) -> None:
    """All candidates of a ring tested at once (arrays) place every label exactly where
    the loop over them one by one does: the same boxes to the last bit, the same drops."""
    placement = place_labels(
        asked, font_px=14, picture=PICTURE, markers=markers, reserved=reserved
    )
    placed, dropped = reference_place(
        asked, font_px=14, picture=PICTURE, markers=markers, reserved=reserved
    )
    assert list(placement.placed) == placed
    assert [(b.x0, b.y0, b.x1, b.y1) for b in (p.box for p in placement.placed)] == [
        (b.x0, b.y0, b.x1, b.y1) for b in (p.box for p in placed)
    ]
    assert list(placement.dropped) == dropped


@given(st.lists(points, min_size=1, max_size=12))
def test_a_roomy_picture_places_every_label_and_near_its_anchor_when_it_can(
    anchors,
) -> None:
    inside = [(min(max(x, 60), 580), min(max(y, 60), 340)) for x, y in anchors]
    asked = [LabelRequest(f"H{k}", a) for k, a in enumerate(inside)]
    placement = place_labels(asked, font_px=12, picture=PICTURE)
    assert not placement.dropped
    check(placement, [], [], PICTURE)
    # The first label has the whole picture to itself: beside its anchor, no leader.
    first = placement.placed[0]
    assert first.leader is None
    assert first.box.distance_to(first.request.anchor) <= 12 / 2 * 1.5 + 1e-9


def test_labels_at_one_point_are_fanned_out_not_stacked() -> None:
    asked = [LabelRequest(t, (320.0, 200.0)) for t in ("H2", "D2", "M2", "L2")]
    placement = place_labels(asked, font_px=20, picture=PICTURE)
    assert len(placement.placed) == 4
    check(placement, [], [], PICTURE)


def test_a_label_never_covers_its_own_marker() -> None:
    cross = Box(300, 190, 320, 210)
    asked = [LabelRequest("H1", (310.0, 200.0), clearance=12)]
    placement = place_labels(asked, font_px=10, picture=PICTURE, markers=[cross])
    (placed,) = placement.placed
    assert not placed.box.overlaps(cross)
    assert placed.leader is None  # right beside it


def test_centred_labels_sit_on_their_anchor_when_free() -> None:
    placement = place_labels(
        [LabelRequest("3", (100.0, 100.0), centred=True)], font_px=10, picture=PICTURE
    )
    box = placement.placed[0].box
    assert (box.x0 + box.x1) / 2 == pytest.approx(100.0)
    assert (box.y0 + box.y1) / 2 == pytest.approx(100.0)


def test_a_full_picture_drops_labels_instead_of_overlapping() -> None:
    w, h = label_size("H1", 10)
    picture = (w * 2, h)  # room for two labels exactly
    asked = [LabelRequest("H1", (1.0, 1.0)) for _ in range(4)]
    placement = place_labels(asked, font_px=10, picture=picture)
    assert len(placement.placed) == 2
    assert len(placement.dropped) == 2
    check(placement, [], [], picture)


def test_degenerate_inputs() -> None:
    # Nothing to place; a picture smaller than any label; anchors far outside.
    assert place_labels([], font_px=10, picture=PICTURE).placed == ()
    tiny = place_labels([LabelRequest("goal", (5.0, 5.0))], font_px=10, picture=(8, 8))
    assert tiny.placed == () and len(tiny.dropped) == 1
    far = place_labels(
        [LabelRequest("L1", (-500.0, 9000.0))], font_px=10, picture=PICTURE
    )
    check(far, [], [], PICTURE)
    assert len(far.placed) == 1 and far.placed[0].leader is not None
    # Boxes that only touch do not overlap.
    assert not Box(0, 0, 1, 1).overlaps(Box(1, 0, 2, 1))
    assert area_overlap(Box(0, 0, 1, 1), Box(1, 0, 2, 1)) == 0
