"""The free space: obstacles expanded by the robot, and the border every planner reads.

- :mod:`planners.space.expansion`: the configuration space (section 9.3): obstacles
  grown by the robot's shape, their union, the walls; what is derived from it is kept on
  it (:meth:`~planners.space.expansion.ConfigurationSpace.derive`).
- :mod:`planners.space.border`: the one model of the free space's border (flat edge
  arrays with arclength) and its edge index, read by the sensor, TangentBug, Bug2 and
  the visibility graphs.
- :mod:`planners.space.geometry`: the small plane geometry every planner measures with,
  one copy of each helper.

The planners above (:mod:`planners.visibility`, :mod:`planners.bug`) import these
modules; nothing here imports them.
"""
