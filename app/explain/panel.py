"""The Explain panel: step through a method as the chapter does.

A folder *Explain* in the GUI: choose a method (obstacle expansion, VG, SVG, DSB), then
step forward and back, jump to the start or the end, or drag a slider over the steps.
The scene shows the current step (:class:`app.explain.view.ExplainView`) and the panel
its line of text, and for DSB the table of the O_i and the flowchart of Fig. 9.15 with
the current box highlighted.

Explanations are computed on demand, in a thread of their own (:class:`Explainer`):
never while Explain is off, never on the scheduler's drag path. The panel is a view of
the controller (:meth:`render` keeps the newest frame and wakes the thread); while a
handle is dragged the overlay is hidden and nothing is computed; once the drag ends the
new scene is explained and shown at the same step number where it still exists.

One :class:`ExplainPanel` holds the state (the explainer, the drawing, the layers it
hid); its folders (:class:`ExplainFolder`) only show that state and call its commands.
A classroom has one panel and one folder per presenter's browser (the laptop and the
projector): a step taken in one is the step shown in all (:mod:`app.classroom`).
"""

from __future__ import annotations

__all__ = [
    "HIDDEN_LAYERS",
    "METHOD_TITLES",
    "ExplainFolder",
    "ExplainPanel",
    "Explainer",
    "flowchart_html",
    "hidden_layers",
    "table_html",
]

import contextlib
import logging
import pickle
import threading
import time
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from app.explain.view import ExplainView
from app.session.big import BIG_SCENE_VERTICES, scene_vertices
from app.session.pool import Runner
from app.session.scheduler import Pending
from app.ui.scoped import batch
from app.ui.text import html_text, markdown_text
from planners import Memo, PlanOptions, plan_all
from planners.explain import Abandoned, Explanation, Step
from planners.explain.dsb import FLOWCHART, explain_dsb
from planners.explain.expansion import explain_expansion
from planners.explain.svg import explain_svg
from planners.explain.vg import explain_vg

if TYPE_CHECKING:
    import viser

    from app.session.frames import Frame, RobotPose
    from planners.scene import Scene

logger = logging.getLogger(__name__)

METHOD_TITLES: Mapping[str, str] = MappingProxyType(
    {
        "off": "Off",
        "expansion": "Obstacle expansion (9.3)",
        "vg": "Visibility graph (9.4)",
        "svg": "Simplified VG (9.5)",
        "dsb": "DSB (9.6, Fig. 9.15)",
    }
)
"""Method key -> its name in the dropdown."""

IDLE_S = 2.0
"""An explainer's thread ends after this long without work [s]; the next request starts
one. A classroom's copies each have an Explain folder, mostly off: they hold no thread."""

HIDDEN_LAYERS = (
    "vg_edges",
    "vg_path",
    "svg_edges",
    "svg_path",
    "dsb_path",
    "bug2_path",
    "robot",
    "sensing",
)
"""Layers hidden while a method is explained (the explanation draws its own), restored
as they were when Explain is switched off."""


def hidden_layers(method: str) -> tuple[str, ...]:
    """Return the layers hidden while ``method`` is explained.

    Examples
    --------
    >>> "expanded" in hidden_layers("expansion"), "expanded" in hidden_layers("svg")
    (True, False)
    """
    if method == "off":
        return ()
    # The expansion explained is built step by step: the finished one would give it away.
    return (*HIDDEN_LAYERS, "expanded") if method == "expansion" else HIDDEN_LAYERS


def table_html(step: Step) -> str:
    """Return the step's facts (:attr:`Step.detail`) as a small HTML table.

    Examples
    --------
    >>> from planners.explain import Step
    >>> table_html(Step("k", "t", (), (("O_1 *", "0.60 + 9.20 = 9.80"),)))
    '<table style="font-size:0.85em"><tr><td>O_1 *</td><td>0.60 + 9.20 = 9.80</td></tr></table>'
    """
    if not step.detail:
        return ""
    rows = "".join(
        f"<tr><td>{html_text(k)}</td><td>{html_text(v)}</td></tr>"
        for k, v in step.detail
    )
    return f'<table style="font-size:0.85em">{rows}</table>'


def flowchart_html(box: str | None) -> str:
    """Return the flowchart of Fig. 9.15 as HTML boxes, ``box`` highlighted.

    Examples
    --------
    >>> "background:#E69F00" in flowchart_html("leave")
    True
    """
    parts = []
    for key, label in FLOWCHART:
        on = key == box
        style = "border:1px solid #333;border-radius:3px;padding:1px 4px;margin:0;" + (
            "background:#E69F00;font-weight:bold;" if on else "background:#f4f4f4;"
        )
        parts.append(f'<div style="{style}">{html_text(label)}</div>')
    arrows = '<div style="text-align:center;color:#666;line-height:1">&darr;</div>'
    return (
        '<div style="font-size:0.75em"><b>Fig. 9.15</b> (DSB flowchart)'
        + arrows.join(parts)
        + "</div>"
    )


class Explainer:
    """Keeps the explanation of the newest scene and the current step; computes in a thread.

    The thread runs while there is work (a :class:`app.session.pool.Runner` of one): a
    request starts it, and it ends after :data:`IDLE_S` without one.

    Pure of viser: it draws through ``draw(step, explanation)``, a callable the panel
    gives. ``render(frame)`` only stores the frame and wakes the thread, so it never
    blocks the scheduler.
    """

    def __init__(
        self,
        draw: Callable[[Step | None, Explanation | None], None],
        turns: threading.Semaphore | None = None,
    ) -> None:
        self._draw = draw
        self._turns = (
            turns  # computations allowed at once, shared (a classroom's copies)
        )
        self._cond = threading.Condition()
        self._frame: Frame | None = None
        self._method = "off"
        self._obstacle = 1
        self._step = 0
        self._dirty = False
        self._busy = False
        self._closed = False
        self._key: tuple[Any, ...] | None = None
        self._explanation: Explanation | None = None
        self._error: str | None = None
        self._memo = Memo()
        # The request this thread serves now (None between requests): what a long
        # explanation is asked to go on with (_asked_to_stop).
        self._serving: tuple[int, str, int] | None = None
        self._server: threading.Thread | None = None  # the thread serving it
        self._runner = Runner(1, name="explain", idle=IDLE_S)

    # ---------------------------------------------------------------- questions

    @property
    def method(self) -> str:
        """The method explained, or ``"off"``."""
        return self._method

    @property
    def obstacle(self) -> int:
        """The obstacle whose expansion is explained (1-based)."""
        return self._obstacle

    @property
    def step(self) -> int:
        """The current step number (0-based)."""
        return self._step

    @property
    def explanation(self) -> Explanation | None:
        """The explanation shown (None while off or not yet computed)."""
        return self._explanation

    @property
    def error(self) -> str | None:
        """Why the last explanation failed, in one line (None when it did not)."""
        return self._error

    # ---------------------------------------------------------------- commands

    def render(self, frame: Frame) -> None:
        """Keep the newest frame; explain it later if a method is on (never blocks)."""
        with self._cond:
            self._frame = frame
            if self._method != "off":
                self._wake()

    def choose(self, method: str, obstacle: int | None = None) -> None:
        """Explain ``method`` (``"off"`` stops); ``obstacle`` for the expansion."""
        if method not in METHOD_TITLES:
            raise ValueError(f"unknown method {method!r}")
        with self._cond:
            if method != self._method:
                self._step = 0
            self._method = method
            if obstacle is not None:
                self._obstacle = max(1, int(obstacle))
            self._wake()

    def go(self, n: int) -> None:
        """Show step ``n`` (clamped to the steps there are)."""
        with self._cond:
            self._step = self._clamp(int(n))
            self._wake()

    def move(self, delta: int) -> None:
        """Step forward (``+1``) or back (``-1``)."""
        with self._cond:
            self._step = self._clamp(self._step + int(delta))
            self._wake()

    def to_end(self) -> None:
        """Jump to the last step."""
        self.go(1 << 30)

    def wait_ready(self, timeout: float = 30.0) -> bool:
        """Block until the current choice is computed and drawn; False on timeout."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while self._dirty or self._busy:
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._cond.wait(left)
        return True

    def close(self) -> None:
        """Stop the thread (if it runs)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._runner.close()

    # ---------------------------------------------------------------- the thread

    def _wake(self) -> None:
        """Ask the thread for a round (under the condition)."""
        self._dirty = True
        self._cond.notify_all()
        self._runner.wake(self._serve)

    def _clamp(self, n: int) -> int:
        count = len(self._explanation.steps) if self._explanation is not None else 1
        return min(max(n, 0), count - 1)

    def _serve(self) -> None:
        """Compute and draw the newest request, if there is one (the runner's thread)."""
        with self._cond:
            if self._closed or not self._dirty:
                return
            self._dirty, self._busy = False, True
            frame, method, obstacle = self._frame, self._method, self._obstacle
            self._server = threading.current_thread()
        try:
            self._update(frame, method, obstacle)
        except Abandoned:
            pass  # something else was asked for meanwhile: the next round takes it
        finally:
            self._serving = None
            with self._cond:
                self._server = None
                self._busy = False
                self._cond.notify_all()

    def _update(self, frame: Frame | None, method: str, obstacle: int) -> None:
        if method == "off" or frame is None or frame.dragging:
            # Off, or a drag in progress: show nothing rather than a stale story.
            self._draw(None, None)
            return
        key = (frame.version, method, obstacle)
        self._serving = key
        if key != self._key:
            plans = _frame_plans(frame, method)
            if plans is None and method != "expansion":
                waiting = _not_here(frame, method)
                if waiting is not None:
                    # A big scene is planned by its worker only: explain its plans once
                    # they come (the next frame), never plan it in the server's process.
                    # Until then no explanation is kept (an older scene's would be
                    # stepped through); the step number stays for the next one.
                    with self._cond:
                        self._key, self._explanation = None, None
                    self._error = waiting or None
                    self._draw(None, None)  # again on each progress frame: cheap
                    return
            with self._turns or contextlib.nullcontext():
                explanation = self._compute(frame.scene, method, obstacle, plans)
            with self._cond:
                self._key, self._explanation = key, explanation
                # The same step number on the new scene, where it still exists.
                self._step = self._clamp(self._step)
        with self._cond:
            if self._closed:  # closed while computing: the panel hid its drawing
                return
            explanation, n = self._explanation, self._step
        self._draw(self._make_step(explanation, n), explanation)

    def _make_step(self, explanation: Explanation | None, n: int) -> Step | None:
        """Return step ``n``, made now if it is made when shown; None if making it failed.

        A step that fails says why in the panel (as an explanation that fails does):
        the thread goes on with the next request.
        """
        if explanation is None:
            return None
        try:
            step = explanation.step(n)
        except Abandoned:
            raise
        except Exception as error:  # a bug in a step must not stop Explain
            logger.exception(
                "making step %d of the %s explanation", n, explanation.method
            )
            self._error = _why(error)
            return None
        self._error = None  # a step before may have failed; this one did not
        return step

    def _asked_to_stop(self) -> bool:
        """Answer the question a long explanation asks as it goes (``abandoned``).

        True once something else is wanted than the request this thread serves: a newer
        scene (an edit), a drag, another method or obstacle, or the panel closed. A big
        scene's explanation, or one of its steps, then stops at its next question (1,024
        nodes, edges or segments of work apart) instead of running to its end before the
        next one starts (:class:`planners.explain.Abandoned`). Asked from any other thread,
        or between requests (a script making a step of :attr:`explanation`), False.
        """
        key = self._serving
        if key is None or threading.current_thread() is not self._server:
            return False
        frame = self._frame  # read without the lock: a stale answer costs a turn
        return (
            self._closed
            or frame is None
            or bool(frame.dragging)
            or (frame.version, self._method, self._obstacle) != key
        )

    def _compute(
        self,
        scene: Scene,
        method: str,
        obstacle: int,
        plans: Mapping[str, Any] | None,
    ) -> Explanation | None:
        try:
            self._error = None
            return _explain(
                scene,
                method,
                obstacle,
                self._memo,
                plans=plans,
                abandoned=self._asked_to_stop,
            )
        except Abandoned:
            raise
        except Exception as error:  # a bug in an explanation must not stop the app
            self._error = _why(error)
            return None


def _why(error: Exception) -> str:
    """Say in one line why an explanation, or one of its steps, failed."""
    return f"{type(error).__name__}: {error}".splitlines()[0]


def _explain(
    scene: Scene,
    method: str,
    obstacle: int,
    memo: Memo,
    *,
    plans: Mapping[str, Any] | None = None,
    abandoned: Callable[[], bool] | None = None,
) -> Explanation:
    """Explain ``method`` on ``scene`` from ``plans`` (the frame's), or plan it first.

    ``abandoned`` goes to the methods whose big scenes take long (the VG's vertex
    steps, the SVG's tags); the expansion's and DSB's explanations are quick.
    """
    options = PlanOptions()
    if method == "expansion":
        return explain_expansion(scene, options, obstacle=obstacle)
    if plans is None:
        plans = plan_all(scene, (method,), options, memo=memo)
    if method == "dsb":
        return explain_dsb(scene, options, plans=dict(plans))
    explain_fn = explain_vg if method == "vg" else explain_svg
    return explain_fn(scene, options, plans=dict(plans), abandoned=abandoned)


def _frame_plans(frame: Frame, method: str) -> Mapping[str, Any] | None:
    """Return the frame's plans when they hold this scene's answer for ``method``.

    The app's planners computed them (with the same default options the explanation
    uses): explaining them is explaining what the screen shows, without planning again.
    None when they belong to an older scene (stale, lagging), are still computing, or
    the planner is switched off.
    """
    plans = frame.plans
    result = plans.get(method)
    if (
        frame.stale
        or method in frame.lagging
        or result is None
        or isinstance(result, Pending)
    ):
        return None
    status = getattr(result, "status", None)
    if status == "error" or (status != "invalid" and plans.get("cspace") is None):
        return None  # a planner that failed: planned here, its error shown
    return _own_copy({k: plans[k] for k in (method, "cspace") if k in plans})


def _own_copy(plans: Mapping[str, Any]) -> dict[str, Any]:
    """Return a copy of the plans an explanation reads, for the explain thread alone.

    GEOS's prepared geometries are not safe to use from two threads at once
    (libgeos/geos#825), and shapely lets go of the GIL in its predicates; the fast lane
    (the next edit starts from this configuration space), the views and the live robot
    go on using the frame's. A pickled copy has geometries of its own and nothing
    derived: a few milliseconds, in this thread.
    """
    return pickle.loads(pickle.dumps(dict(plans), protocol=pickle.HIGHEST_PROTOCOL))


def _not_here(frame: Frame, method: str) -> str | None:
    """Say why ``method`` is not planned here for a big scene, or None to plan it.

    A big scene (:mod:`app.session.big`) is planned by its worker: while it computes (a stale
    frame with its progress), "" (wait, say nothing more); when the frame has no plan
    of ``method`` (switched off), what to do about it; when the planner failed, why.
    """
    if frame.stale or frame.progress is not None:
        return ""
    count = scene_vertices(frame.scene)
    if count <= BIG_SCENE_VERTICES:
        return None
    result = frame.plans.get(method)
    if result is None or method not in frame.enabled:
        return (
            f"Switch on {METHOD_TITLES[method]} to explain it: a scene of {count:,} "
            "vertices is planned by its worker only."
        )
    reason = getattr(result, "reason", None) or "no plan of this scene"
    return f"{METHOD_TITLES[method]} has nothing to explain here: {reason}"


class ExplainFolder:
    """One browser's *Explain* folder: its widgets, each calling one panel command.

    It holds no state of its own: :meth:`show` puts the panel's state into the widgets
    (the method, the obstacle, the step's line, slider, table and flowchart), so several
    folders of one :class:`ExplainPanel` (a lecturer's laptop and projector) always agree.
    """

    def __init__(self, gui: viser.GuiApi, panel: ExplainPanel) -> None:
        self._owner = gui._owner  # the browser (or server) whose panel it is
        self.handle = gui.add_folder("Explain", expand_by_default=False)
        """The folder itself (:meth:`remove` takes it off its browser's panel)."""
        with self.handle:
            self.method = gui.add_dropdown("Method", list(METHOD_TITLES.values()))
            self.obstacle = gui.add_number("Obstacle", 1, min=1, max=99, step=1)
            self.nav = gui.add_button_group("Step", ["|<", "<", ">", ">|"])
            # Numbered from 1, as the text says "step n of N".
            self.slider = gui.add_slider("Step no.", 1, 2, 1, 1)
            self.text = gui.add_markdown("*Choose a method to step through it.*")
            self.flowchart = gui.add_html("")
            self.table = gui.add_html("")
        self._bind(panel)

    def remove(self) -> None:
        """Take the folder and its widgets off the browser's panel."""
        self.handle.remove()

    def _bind(self, panel: ExplainPanel) -> None:
        titles = {v: k for k, v in METHOD_TITLES.items()}
        explainer = panel.explainer

        # A widget the server sets calls back with no client: only a browser's counts.
        @self.method.on_update
        def _(event: Any) -> None:
            if event.client is not None:
                panel.choose(titles[event.target.value])

        @self.obstacle.on_update
        def _(event: Any) -> None:
            if event.client is not None:
                panel.choose(explainer.method, int(event.target.value))

        @self.nav.on_click
        def _(event: Any) -> None:
            actions = {
                "|<": lambda: explainer.go(0),
                "<": lambda: explainer.move(-1),
                ">": lambda: explainer.move(1),
                ">|": explainer.to_end,
            }
            actions[event.target.value]()

        @self.slider.on_update
        def _(event: Any) -> None:
            if event.client is not None:
                explainer.go(int(event.target.value) - 1)

    def show_choice(self, method: str, obstacle: int) -> None:
        """Show the method and obstacle chosen (in this browser or another)."""
        with batch(self._owner):
            self.method.value = METHOD_TITLES[method]
            self.obstacle.value = obstacle

    def show(
        self,
        step: Step | None,
        explanation: Explanation | None,
        n: int,
        words: str,
    ) -> None:
        """Show step ``n`` of ``explanation`` (None: ``words`` say why there is none)."""
        with batch(self._owner):
            if explanation is None or step is None:
                self.text.content = words
                self.table.content = self.flowchart.content = ""
                return
            self.slider.max = max(2, len(explanation.steps))
            self.slider.value = n + 1
            self.text.content = (
                f"**{markdown_text(explanation.title)}**, step {n + 1} of "
                f"{len(explanation.steps)}\n\n{markdown_text(step.text, lines=True)}"
            )
            self.table.content = table_html(step)
            dsb = explanation.method == "dsb"
            box = step.kind.split(":", 1)[1] if dsb and ":" in step.kind else None
            self.flowchart.content = flowchart_html(box) if dsb else ""


class ExplainPanel:
    """The explanation's state and layer in the scene, and the *Explain* folders showing it.

    A view of the controller (``render``, ``render_robot``). One :class:`Explainer`, one
    drawing on ``server.scene`` and one set of layers it hid, however many folders: each
    folder's callbacks call the panel's commands (choosing a method also hides the plans'
    layers, restored when Explain goes off), and every folder shows the same state.

    Alone (one session), its folder is built on ``server.gui`` (or ``gui``). In a
    classroom (``folder=False``) each presenter's browser adds its own with
    :meth:`add_folder` and takes it away with :meth:`remove_folder`; when the last one
    goes, nobody could switch Explain off, so it goes off.
    """

    def __init__(
        self,
        server: viser.ViserServer,
        controller: Any,
        *,
        gui: viser.GuiApi | None = None,
        folder: bool = True,
        turns: threading.Semaphore | None = None,
    ) -> None:
        self._controller = controller
        self._view = ExplainView(server.scene)
        self._atomic = server.atomic  # a step is drawn as one update
        self._saved_layers: dict[str, bool] | None = None
        self._layers: Mapping[str, bool] = {}
        self._scene: Scene | None = None
        self._lock = threading.RLock()  # guards the folders, the layers saved, _shown
        self._folders: tuple[ExplainFolder, ...] = ()
        self._shown: tuple[Step | None, Explanation | None] = (None, None)
        self.explainer = Explainer(self._draw, turns)
        self.folder = (
            self.add_folder(server.gui if gui is None else gui) if folder else None
        )
        """The folder built with the panel (None in a classroom: one per presenter)."""

    # ---------------------------------------------------------------- folders

    @property
    def folders(self) -> tuple[ExplainFolder, ...]:
        """The folders showing this panel (one per presenter's browser in a classroom)."""
        return self._folders

    def add_folder(self, gui: viser.GuiApi) -> ExplainFolder:
        """Build an *Explain* folder on ``gui`` showing the panel's state as it is now."""
        folder = ExplainFolder(gui, self)
        with self._lock:
            self._folders = (*self._folders, folder)
            step, explanation = self._shown
            _safely(folder.show_choice, self.explainer.method, self.explainer.obstacle)
            _safely(folder.show, step, explanation, self.explainer.step, self._words())
        return folder

    def remove_folder(self, folder: ExplainFolder) -> None:
        """Stop showing ``folder`` (its browser left); the last one turns Explain off."""
        with self._lock:
            self._folders = tuple(f for f in self._folders if f is not folder)
            last = not self._folders
        if last:
            self.choose("off")

    # ---------------------------------------------------------------- commands

    def choose(self, method: str, obstacle: int | None = None) -> None:
        """Explain ``method`` (a key of :data:`METHOD_TITLES`), hiding the plans' layers."""
        with self._lock:
            if method != self.explainer.method:
                self._restore_layers()
                if method != "off":
                    self._hide_layers(hidden_layers(method))
            self.explainer.choose(method, obstacle)
            for folder in self._folders:
                _safely(folder.show_choice, method, self.explainer.obstacle)

    def _hide_layers(self, keys: tuple[str, ...]) -> None:
        self._saved_layers = {k: bool(self._layers.get(k, True)) for k in keys}
        for key in keys:
            if key in self._layers:
                self._controller.set_layer(key, False)

    def _restore_layers(self) -> None:
        if self._saved_layers is None:
            return
        for key, visible in self._saved_layers.items():
            if key in self._layers:
                self._controller.set_layer(key, visible)
        self._saved_layers = None

    # ---------------------------------------------------------------- the view protocol

    def render(self, frame: Frame) -> None:
        """Keep the newest frame (see :meth:`Explainer.render`)."""
        self._layers = frame.layers
        self._scene = frame.scene
        self.explainer.render(frame)

    def render_robot(self, pose: RobotPose | None) -> None:
        """Nothing: the explanation does not move with the robot."""

    def close(self, *, hide: bool = True) -> None:
        """Give the plans' layers back, stop the explanation thread and hide its drawing.

        ``hide=False`` leaves the drawing to its owner, which removes it (a private copy's
        browser may be gone: nothing should be sent to it).
        """
        with self._lock:
            self._restore_layers()
        self.explainer.close()
        if hide:
            self._view.show(None)

    # ---------------------------------------------------------------- drawing

    def draw_text(self, on: bool) -> None:
        """Draw the step's caption and labels in the scene (True, the app), or not (a picture draws its own)."""
        with self._lock:
            self._view.draw_text(on)
            step, explanation = self._shown
            self._draw(step, explanation)

    def _draw(self, step: Step | None, explanation: Explanation | None) -> None:
        n = self.explainer.step
        caption = ""
        if step is None or explanation is None:
            step, explanation = None, None
        else:
            caption = f"{n + 1}/{len(explanation.steps)}  {step.text}"
        with self._atomic():
            self._view.show(step, caption, self._scene)
        with self._lock:
            self._shown = (step, explanation)
            words = self._words()
            for folder in self._folders:
                _safely(folder.show, step, explanation, n, words)

    def _words(self) -> str:
        """Return what a folder says when no step is shown (off, failed, computing)."""
        error = self.explainer.error
        if self.explainer.method == "off":
            return "*Choose a method to step through it.*"
        return f"*{markdown_text(error)}*" if error else "*Explaining the scene...*"


def _safely(show: Callable[..., None], *args: Any) -> None:
    """Update one browser's folder: a browser that just left must not stop the others."""
    try:
        show(*args)
    except Exception:
        logger.exception("an Explain folder failed to update")
