"""Screenshot tests: every shipped scenario, drawn by the app in headless Chromium.

Each scenario is rendered top-down at 960 x 600 as the slide picture of
:mod:`app.media.pictures` (title, legend and labels sized for the picture), one scenario
after the other in one app and one page, as a batch of ``--snapshot`` pictures does, and
compared with its golden PNG in ``tests/snapshots/``.
Tolerance, refreshing and diffs: ``tests/snapshots/README.md``. Each scenario's labels, as
the browser laid them out, are checked too: none overlaps another or a marker.

- A pixel *differs* when any RGB channel differs by more than ``PIXEL_THRESHOLD`` counts.
- A picture *matches* when at most ``MAX_DIFF_SHARE`` of its pixels differ (and it has the
  golden's size).
- ``UPDATE_SNAPSHOTS=1`` (``make snapshots``) rewrites the goldens; without it a missing
  golden is a failure, never silently created.
- On a mismatch, ``tests/snapshots/_failures/NAME.diff.png`` shows golden | new | what
  moved (differing pixels in red), next to ``NAME.actual.png``.
"""

from __future__ import annotations

import dataclasses
import io
import os
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image, ImageDraw, ImageFont

from app import start_app
from app.media.pictures import Studio, open_studio
from app.media.slides import Slide
from app.ui.labels import Box
from planners.scene import Scene, load_scene, move_obstacle, save_scene

if TYPE_CHECKING:
    from playwright.sync_api import Browser

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "static_scenarios").glob("*.json"))
SNAPSHOTS = Path(__file__).resolve().parent / "snapshots"
FAILURES = SNAPSHOTS / "_failures"

WIDTH, HEIGHT = 960, 600
"""Size of the goldens [px]: big enough to read labels, small enough for the repository."""
PIXEL_THRESHOLD = 16
"""A pixel differs when some RGB channel differs by more than this (of 255)."""
MAX_DIFF_SHARE = 0.005
"""A picture matches when at most this share of its pixels differ (0.5 %)."""
UPDATE = os.environ.get("UPDATE_SNAPSHOTS") == "1"
LABEL_HEIGHT = 22  # [px] title strip above the three panels of a diff image


@dataclasses.dataclass(frozen=True)
class Comparison:
    """How a new picture differs from its golden."""

    share: float
    """Share of differing pixels, 0..1 (1 when the sizes differ)."""
    max_delta: int
    """Largest channel difference seen, 0..255."""
    mask: np.ndarray | None
    """(H, W) bool, True where a pixel differs; None when the sizes differ."""
    size_problem: str | None = None

    @property
    def ok(self) -> bool:
        """Tell whether the picture is within the tolerance."""
        return self.size_problem is None and self.share <= MAX_DIFF_SHARE

    def describe(self) -> str:
        """Say how far off the picture is, in one line."""
        if self.size_problem is not None:
            return self.size_problem
        return (
            f"{self.share:.3%} of pixels differ by more than {PIXEL_THRESHOLD} "
            f"(allowed {MAX_DIFF_SHARE:.1%}; largest channel difference {self.max_delta})"
        )


def compare(actual: Image.Image, expected: Image.Image) -> Comparison:
    """Compare two pictures with the documented tolerance."""
    if actual.size != expected.size:
        return Comparison(
            1.0,
            255,
            None,
            f"size {actual.size} differs from the golden's {expected.size}",
        )
    a = np.asarray(actual.convert("RGB"), dtype=np.int16)
    e = np.asarray(expected.convert("RGB"), dtype=np.int16)
    delta = np.abs(a - e).max(axis=2)
    mask = delta > PIXEL_THRESHOLD
    return Comparison(float(mask.mean()), int(delta.max()), mask)


def diff_image(
    actual: Image.Image, expected: Image.Image, comparison: Comparison
) -> Image.Image:
    """Return golden | new | differing pixels in red over a faded copy of the new picture."""
    w, h = expected.size
    actual_rgb = actual.convert("RGB")
    if comparison.mask is None:  # sizes differ: show both, no overlay
        overlay = Image.new("RGB", (w, h), (255, 255, 255))
    else:
        faded = (
            np.asarray(actual_rgb.convert("L").convert("RGB"), dtype=np.float32) * 0.35
            + 165
        )
        faded[comparison.mask] = (230, 0, 0)
        overlay = Image.fromarray(faded.astype(np.uint8))
    label_h = LABEL_HEIGHT
    out = Image.new("RGB", (3 * w, h + label_h), (255, 255, 255))
    draw = ImageDraw.Draw(out)
    font = ImageFont.load_default(size=14)
    for k, (image, title) in enumerate(
        (
            (expected.convert("RGB"), "golden"),
            (actual_rgb, "new"),
            (overlay, f"differs (red): {comparison.describe()}"),
        )
    ):
        out.paste(image, (k * w, label_h))
        draw.text((k * w + 6, 4), title, fill=(0, 0, 0), font=font)
    return out


def check_snapshot(
    name: str, png: bytes, *, failures: Path = FAILURES, update: bool = UPDATE
) -> Comparison | None:
    """Compare ``png`` with golden ``NAME.png``; write it instead when ``update``.

    Returns the comparison (None when the golden was written); fails the test on a
    mismatch or a missing golden, after writing the diff into ``failures``.
    """
    golden = SNAPSHOTS / f"{name}.png"
    actual = Image.open(io.BytesIO(png))
    actual.load()
    if update:
        SNAPSHOTS.mkdir(parents=True, exist_ok=True)
        actual.save(golden, optimize=True)
        return None
    if not golden.exists():
        pytest.fail(
            f"no golden picture {golden.relative_to(ROOT)}; create it with `make snapshots` "
            "(UPDATE_SNAPSHOTS=1) and look at it before committing",
            pytrace=False,
        )
    expected = Image.open(golden)
    comparison = compare(actual, expected)
    stale = [failures / f"{name}.diff.png", failures / f"{name}.actual.png"]
    if comparison.ok:
        for path in stale:
            path.unlink(missing_ok=True)
        return comparison
    failures.mkdir(parents=True, exist_ok=True)
    actual.save(stale[1])
    diff_image(actual, expected, comparison).save(stale[0])
    pytest.fail(
        f"{name}: the picture changed: {comparison.describe()}. See {stale[0]}; if the "
        "change is intended, refresh the goldens with `make snapshots`.",
        pytrace=False,
    )
    raise AssertionError  # unreachable: pytest.fail raises


# Where the browser drew each label (its element's box, and whether its text fits).
LABEL_BOXES_JS = """() => [...document.querySelectorAll('.planner-label')].map(e => {
    const r = e.getBoundingClientRect();
    return {text: e.textContent, box: [r.left, r.top, r.right, r.bottom],
            fits: e.scrollWidth <= e.clientWidth + 1 && e.scrollHeight <= e.clientHeight + 1};
})"""


@dataclasses.dataclass(frozen=True)
class Rendered:
    """A slide picture and what the browser drew of its labels."""

    png: bytes
    labels: list[dict]
    slide: Slide


@pytest.fixture(scope="module")
def studio(browser: Browser) -> Iterator[Studio]:
    """One app in one golden-sized page for the module: each test loads its scenario.

    The same path as a batch of ``--snapshot`` pictures (one page, a scenario after the
    other); a fresh app per picture is what the command line's own tests check.
    """
    planner_app = start_app(SCENARIOS[0], print_url=False)
    try:
        with open_studio(planner_app, browser, width=WIDTH, height=HEIGHT) as shown:
            yield shown
    finally:
        planner_app.stop()


def render_slide(studio: Studio, scenario: Path) -> Rendered:
    """Show ``scenario`` in the shared studio and take its golden-sized slide picture."""
    studio.load(scenario)
    png = studio.picture()
    labels = studio.shown.page.evaluate(LABEL_BOXES_JS)
    assert studio.slide is not None
    return Rendered(png, labels, studio.slide)


def render(studio: Studio, scenario: Path | Scene, folder: Path) -> bytes:
    """The golden-sized slide picture of ``scenario`` (a file, or a scene saved in ``folder``)."""
    if isinstance(scenario, Scene):
        scenario = save_scene(scenario, folder / "scene.json")
    return render_slide(studio, scenario).png


def check_labels(rendered: Rendered, width: int, height: int) -> None:
    """No label overlaps another label, a marker, the title or the legend; all fit."""
    slide = rendered.slide
    drawn = [Box(*d["box"]) for d in rendered.labels]
    assert len(drawn) == len(slide.labels.placed) > 0
    assert not slide.labels.dropped
    others = list(slide.markers)
    others += [
        b
        for b in (slide.title and slide.title[1], slide.legend and slide.legend[1])
        if b
    ]
    for k, (d, box) in enumerate(zip(rendered.labels, drawn, strict=True)):
        assert d["fits"], f"the text of label {d['text']!r} overflows its box"
        assert box.inside(width, height)
        for other in drawn[k + 1 :]:
            assert not box.grown(-0.5).overlaps(other), (d["text"], box, other)
        for other in others:
            assert not box.grown(-0.5).overlaps(other), (d["text"], box, other)


def test_every_scenario_is_covered() -> None:
    assert len(SCENARIOS) >= 1
    if not UPDATE:
        stale = {p.stem for p in SNAPSHOTS.glob("*.png")} - {p.stem for p in SCENARIOS}
        assert not stale, f"goldens without a scenario (delete them): {sorted(stale)}"


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_scenario_snapshot(studio: Studio, path: Path) -> None:
    rendered = render_slide(studio, path)
    check_labels(rendered, WIDTH, HEIGHT)
    check_snapshot(path.stem, rendered.png)


# The two tests below compare against the goldens even under UPDATE_SNAPSHOTS=1 (then
# against the ones this run just wrote, since they run after the scenario tests).


def test_unchanged_scene_passes_twice_in_a_row(studio: Studio, tmp_path: Path) -> None:
    path = SCENARIOS[0]
    for _ in range(2):
        comparison = check_snapshot(
            path.stem, render(studio, path, tmp_path), failures=tmp_path, update=False
        )
        assert comparison is not None and comparison.ok


def test_moved_obstacle_fails_the_comparison(studio: Studio, tmp_path: Path) -> None:
    path = SCENARIOS[0]
    moved = move_obstacle(load_scene(path), 0, (0.8, 0.6))
    with pytest.raises(pytest.fail.Exception, match="the picture changed"):
        check_snapshot(
            path.stem, render(studio, moved, tmp_path), failures=tmp_path, update=False
        )
    diff = Image.open(tmp_path / f"{path.stem}.diff.png").convert("RGB")
    assert diff.size == (3 * WIDTH, HEIGHT + LABEL_HEIGHT)
    assert Image.open(tmp_path / f"{path.stem}.actual.png").size == (WIDTH, HEIGHT)
    # The third panel shows what moved in red: a visible patch, not a few stray pixels.
    overlay = np.asarray(diff)[LABEL_HEIGHT:, 2 * WIDTH :]
    red = (overlay[..., 0] == 230) & (overlay[..., 1] == 0) & (overlay[..., 2] == 0)
    assert red.mean() > MAX_DIFF_SHARE


def test_compare_tolerance() -> None:
    base = np.full((100, 100, 3), 255, np.uint8)
    golden = Image.fromarray(base)
    faint = base.copy()
    faint[:, :, 0] -= PIXEL_THRESHOLD  # every pixel off by exactly the threshold: same
    assert compare(Image.fromarray(faint), golden).share == 0.0
    few = base.copy()
    few[0, :50] = 0  # 50 of 10 000 pixels: 0.5 %, still within the tolerance
    assert compare(Image.fromarray(few), golden).ok
    more = base.copy()
    more[0, :51] = 0
    assert not compare(Image.fromarray(more), golden).ok
    assert not compare(Image.new("RGB", (100, 99)), golden).ok


def test_missing_golden_fails_instead_of_being_created(tmp_path: Path) -> None:
    buffer = io.BytesIO()
    Image.new("RGB", (8, 8), (255, 255, 255)).save(buffer, format="PNG")
    with pytest.raises(pytest.fail.Exception, match="no golden picture"):
        check_snapshot(
            "no_such_scenario", buffer.getvalue(), failures=tmp_path, update=False
        )
    assert not (SNAPSHOTS / "no_such_scenario.png").exists()
