"""Robots that sense as they go: TangentBug (the distance-sensor-based method), Bug2, the live robot.

- :mod:`planners.bug.tangent_bug`: TangentBug's entry point (section 9.6, Fig. 9.15):
  the step, the run, the trace; its records are public there.
- ``_context`` (the records and small geometry both modes share, and the leave rule's
  protocol), ``_seek`` (goal seeking), ``_follow`` (boundary following) and ``_leave``
  (the leave rules): TangentBug's parts, used by their siblings only.
- :mod:`planners.bug.sensor`: the 360-degree range sensor on the border.
- :mod:`planners.bug.trace`: a walked path and the questions asked of it.
- :mod:`planners.bug.bug2`: Bug2, a contact sensor on the m-line.
- :mod:`planners.bug.live`: TangentBug driven among moving obstacles with wheel limits.
"""
