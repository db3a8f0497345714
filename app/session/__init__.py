"""One scene for one audience, without viser: the controller and the parts it is made of.

- :mod:`app.session.controller`: the :class:`Controller`, a small facade over the rest.
- ``_state`` (the scene, its version, the history and the UI state under one lock),
  :mod:`app.session.history` (undo and redo, pure) and :mod:`app.session.tools` (mouse
  tools and picking, pure): what an edit changes.
- :mod:`app.session.scheduler` (two planning lanes, coalescing), :mod:`app.session.lanes`
  (the slow planners' worker process), :mod:`app.session.big` (big scenes planned in a
  worker) and :mod:`app.session.pool` (workers the private copies share): who plans when.
- :mod:`app.session.frames` (what views draw), :mod:`app.session.playback` (the robot's
  motion) and :mod:`app.session.robot` (its kinematics glue).
- :mod:`app.session.files`: the scenes folder on the server's disk.

Nothing here imports viser: a worker process that needs only the controller stays light.
"""
