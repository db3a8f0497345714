"""Draw a :class:`app.ui.view.PlannerView` under a root node, for everyone or for one browser.

In a classroom (:mod:`app.classroom`) the presenter's scene is drawn once for every
browser under ``/shared`` (viser's broadcast scope); a browser that edits it has its
gizmos under ``/own`` in its client scope, over the shared drawing, and a browser on a
private copy draws its own view there. viser 1.1.1 lets a client-scoped node *shadow*
the broadcast node of the same name for that one browser; a hidden client-scoped
``/shared`` therefore hides the whole shared drawing from a browser on a copy.

:class:`ScopedTarget` is what :class:`PlannerView` takes as its target: a ``scene`` whose
``add_*`` methods prefix every node name with the root, and the owner's ``atomic``. With
``inert=True`` the gizmos the view asks for are plain frames: the markers and labels still
hang from them and move with the scene, but nobody can drag them and no message from a
browser can move them (no transform control of that name exists on the server).
"""

from __future__ import annotations

__all__ = ["InertGizmo", "PrefixedScene", "ScopedTarget", "batch", "left", "quietly"]

import contextlib
from collections.abc import Callable, Iterator
from typing import Any, cast

import viser


def left(client: viser.ClientHandle) -> bool:
    """Whether ``client``'s browser has left (what is queued for it is never sent)."""
    return bool(client._websock_connection.get_message_buffer().done)


@contextlib.contextmanager
def quietly(owner: Any) -> Iterator[None]:
    """Let what is drawn for one browser meet its leaving quietly.

    ``owner`` is a ``viser.ViserServer``, a ``viser.ClientHandle`` or None (nothing to
    do for a server or None). One browser may
    leave while its view or panel is drawn: the rest of that drawing goes nowhere
    (viser would warn, once per browser, of messages it will never deliver; a view is
    taken off its session when its browser leaves, so no drawing follows).
    """
    if isinstance(owner, viser.ClientHandle):
        with owner._websock_connection.get_message_buffer().sanctioned_dead_writes():
            yield
    else:
        yield


@contextlib.contextmanager
def batch(owner: Any) -> Iterator[None]:
    """Batch ``owner``'s messages (browsers apply them as one update), :func:`quietly`."""
    with owner.atomic(), quietly(owner):
        yield


class InertGizmo:
    """A frame standing in for a gizmo: same position and visibility, nothing to drag."""

    def __init__(self, frame: Any) -> None:
        object.__setattr__(self, "_frame", frame)

    def on_update(self, callback: Callable[[Any], Any]) -> Callable[[Any], Any]:
        """Accept the view's drag callback and never call it (nobody can drag a frame)."""
        return callback

    def __getattr__(self, name: str) -> Any:
        return getattr(object.__getattribute__(self, "_frame"), name)

    def __setattr__(self, name: str, value: Any) -> None:
        setattr(object.__getattribute__(self, "_frame"), name, value)


class PrefixedScene:
    """A viser ``SceneApi`` whose ``add_*`` methods put every node under ``root``.

    Parameters
    ----------
    scene
        ``server.scene`` (every browser) or ``client.scene`` (one browser).
    root
        Name of the root node, e.g. ``"/shared"``; it is created here, as a frame.
    inert
        Replace transform controls (gizmos) by frames (:class:`InertGizmo`).
    browser
        The browser whose scene it is (``client``, for ``client.scene``), else None:
        its gizmos echo nothing back, and what is added after it left goes nowhere
        (:func:`quietly`).
    """

    def __init__(
        self,
        scene: Any,
        root: str,
        *,
        inert: bool = False,
        browser: viser.ClientHandle | None = None,
    ) -> None:
        self._scene = scene
        self.root_name = root
        """Name of the root node."""
        self._inert = inert
        self._browser = browser
        with quietly(browser):
            self.root = scene.add_frame(root, show_axes=False)
        """The root node (remove it to remove everything drawn under it)."""

    def __getattr__(self, name: str) -> Any:
        method = getattr(self._scene, name)
        if not name.startswith("add_"):
            return method
        if name == "add_transform_controls" and self._inert:
            return self._inert_gizmo

        def add(node: str, *args: Any, **kwargs: Any) -> Any:
            self._ensure_root()
            if self._browser is None:
                return method(self.root_name + node, *args, **kwargs)
            with quietly(self._browser):
                handle = method(self.root_name + node, *args, **kwargs)
            if name == "add_transform_controls":
                _no_echo(handle)
            return handle

        return add

    def _ensure_root(self) -> None:
        """Refuse to add a node once the root is removed.

        viser would accept it and make the missing root again, visible: a view drawn
        late, after its browser left, would bring back nodes nobody removes. Assigning
        to a removed node raises already; so does adding one here.
        """
        if self.root._impl.removed:
            raise RuntimeError(f"{self.root_name} was removed: nothing more is drawn")

    def _inert_gizmo(self, node: str, **kwargs: Any) -> InertGizmo:
        self._ensure_root()
        frame = self._scene.add_frame(
            self.root_name + node,
            show_axes=False,
            position=kwargs.get("position", (0.0, 0.0, 0.0)),
            visible=kwargs.get("visible", True),
        )
        return InertGizmo(frame)


def _no_echo(gizmo: Any) -> None:
    """Stop viser echoing a one-browser gizmo's every move to the other browsers.

    viser 1.1.1 answers each move of a gizmo with its new pose for every *other*
    browser of the gizmo's scope (so two tabs of one scene stay together). A gizmo in
    one browser's scope has no other browser: the echo is two messages per move, each
    waking the server's event loop, for nobody (ten students dragging at 30 Hz made it
    a tenth of a core).
    """
    aux = getattr(gizmo, "_impl_aux", None)
    if aux is not None and hasattr(aux, "sync_cb"):
        aux.sync_cb = None


class ScopedTarget:
    """A :class:`PlannerView` target: a prefixed scene and the owner's ``atomic``.

    Parameters
    ----------
    owner
        A ``viser.ViserServer`` or ``viser.ClientHandle``.
    root
        Root node name (``"/shared"``, ``"/own"``).
    inert
        Gizmos become frames nobody can drag (the shared view of a classroom).
    """

    def __init__(self, owner: Any, root: str, *, inert: bool = False) -> None:
        self.owner = owner
        """The server or client handle drawn on."""
        self.prefixed = PrefixedScene(
            owner.scene,
            root,
            inert=inert,
            browser=owner if isinstance(owner, viser.ClientHandle) else None,
        )
        """The prefixed scene."""
        # What the view calls on it is SceneApi's add_* methods, prefixed.
        self.scene = cast(viser.SceneApi, self.prefixed)
        """The prefixed scene, as the view sees it (a viser ``SceneApi``)."""

    def atomic(self) -> contextlib.AbstractContextManager[None]:
        """Batch the owner's messages (clients apply it as one update: :func:`batch`)."""
        return batch(self.owner)

    def remove(self) -> None:
        """Remove the root and everything drawn under it (in this scope)."""
        self.prefixed.root.remove()
