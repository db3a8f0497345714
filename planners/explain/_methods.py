"""Any explanation by its method's name: the one module that knows all four methods.

It imports the four method modules (which import only the records of
:mod:`planners.explain`'s ``_steps``), so nothing imports back up to it.
"""

from __future__ import annotations

__all__ = ["explain"]

from typing import TYPE_CHECKING, Any

from planners.explain import dsb, expansion, svg, vg
from planners.explain._steps import METHODS, Explanation

if TYPE_CHECKING:
    from planners.registry import PlanOptions
    from planners.scene import Scene


def explain(
    scene: Scene,
    method: str,
    options: PlanOptions | None = None,
    **kwargs: Any,
) -> Explanation:
    """Explain ``method`` (one of :data:`~planners.explain.METHODS`) on ``scene``.

    ``kwargs`` go to the method's function (``obstacle=`` for the expansion;
    ``abandoned=`` for the VG and the SVG, whose big scenes take long: see
    :class:`~planners.explain.Abandoned`).

    Examples
    --------
    >>> import planners
    >>> scene = planners.load_scene("static_scenarios/02_three_obstacles.json")
    >>> [len(planners.explain(scene, m).steps) > 1 for m in METHODS]
    [True, True, True, True]
    """
    table = {
        "expansion": expansion.explain_expansion,
        "vg": vg.explain_vg,
        "svg": svg.explain_svg,
        "dsb": dsb.explain_dsb,
    }
    if method not in table:
        raise ValueError(
            f"unknown method {method!r}; choose one of {', '.join(METHODS)}"
        )
    return table[method](scene, options, **kwargs)
