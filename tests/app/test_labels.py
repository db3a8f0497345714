"""The label placer (app.ui.labels): no two boxes overlap, none covers a marker, all inside.

The properties check every result against slow references that share no code with the
placer: overlap as a positive shapely intersection area, "inside" against the picture
rectangle, and placement again from scratch (the placer is a pure function).
"""

from __future__ import annotations

import itertools

import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from app.ui.labels import Box, LabelRequest, label_size, place_labels

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
