"""The watchers' one panel: drawn once for the whole class, shown only where someone watches.

A watcher's panel shows the presenter's session (results, status, settings, the robot's
wheel rates) with every control disabled. Drawn per browser, 300 watchers cost 300
panels of some sixty widgets to build, and 300 redraws of every frame, each encoded for
its browser. Here the class has one :class:`~app.ui.panels.Panels`, in viser's broadcast
scope: its widgets and their updates are pushed once and encoded once for everyone
(:mod:`app.classroom.wire`).

The panel hangs from a container of its own, :data:`CONTAINER`, which the server never
sends to everyone. A browser draws a widget only inside a container it knows: the
container is sent to one browser (:meth:`WatchPanel.show`) when it starts watching and
taken back (:meth:`WatchPanel.hide`) when it presents, edits or works on its copy, which
have panels of their own. Order does not matter: widgets that arrive before their
container wait in the browser until it comes.

Nobody edits through this panel: its controller is a gate that refuses every edit
(:class:`app.guard.gate.GatedController`), and the door refuses values for its widgets,
which are all disabled (:mod:`app.guard.door`). Its downloads (the scene, the robot's
motion) go to the browser that asked.

Data flow::

    presenter's frame -> Audience (deferred, at most 10 per second)
        -> WatchPanel.panels.render(frame): broadcast widget updates, encoded once
    browser starts watching -> WatchPanel.show(client): the container, to it alone
"""

from __future__ import annotations

__all__ = ["CONTAINER", "WatchPanel"]

from collections.abc import Mapping
from typing import Any, cast

import viser
from viser import _messages
from viser._gui_handles import GuiFolderHandle, _GuiHandleState

from app.guard.gate import GatedController, Refusals
from app.session.controller import Controller
from app.ui.panels import Panels
from app.ui.scoped import quietly
from planners.registry import PlannerSpec

CONTAINER = "classroom-watchers-panel"
"""uuid of the container the watchers' panel hangs from (sent only to watchers)."""

ORDER = 0.0
"""Where the panel sits: below a seat's banner and buttons (negative orders)."""


class WatchPanel:
    """The class's one watcher panel, in the broadcast scope (see the module's text).

    Parameters
    ----------
    server
        The viser server.
    controller
        The presenter's session, which the panel shows.
    titles
        Scenario key -> title, for the scenario dropdown.
    registry
        The planners of the session.
    refusals
        Where the gate counts the edits it refuses.
    never
        Actions refused even when reading (saving to the lecturer's folder).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        controller: Controller,
        *,
        titles: Mapping[str, str],
        registry: Mapping[str, PlannerSpec],
        refusals: Refusals,
        never: frozenset[str] = frozenset(),
    ) -> None:
        self._server = server
        # The container exists on the server (the widgets' parent) but its creation is
        # never pushed to the broadcast buffer: no browser draws it until shown.
        props = _messages.GuiFolderProps(
            order=ORDER, label=None, visible=True, expand_by_default=True
        )
        self._props = props
        self.container = GuiFolderHandle(
            _GuiHandleState(
                CONTAINER, server.gui, None, props=props, parent_container_id="root"
            )
        )
        with self.container:
            self.panels = Panels(server, titles, registry, None, floor_clicks=False)
        gated = GatedController(controller, lambda: False, refusals, never=never)
        self.panels.attach(cast(Controller, gated))
        self.panels.lock(True, saving=False)

    def show(self, client: viser.ClientHandle) -> None:
        """Show the panel in ``client``'s browser (and only there)."""
        _queue(
            client,
            _messages.GuiFolderMessage(
                uuid=CONTAINER, container_uuid="root", props=self._props
            ),
        )

    def hide(self, client: viser.ClientHandle) -> None:
        """Take the panel away from ``client``'s browser (its widgets stay, unseen)."""
        _queue(client, _messages.GuiRemoveMessage(uuid=CONTAINER))


def _queue(client: viser.ClientHandle, message: Any) -> None:
    """Send ``message`` to one browser, in order with the rest of its own messages."""
    with quietly(client):  # it may have left meanwhile
        client._websock_connection.queue_message(message)
