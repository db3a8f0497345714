"""What a browser sees: the 3-D view, the panel and what both share.

- :mod:`app.ui.view`: the 3-D scene (:class:`PlannerView`).
- :mod:`app.ui.panels`: the GUI panel.
- :mod:`app.ui.style`: colours, sizes and heights.
- :mod:`app.ui.thinning`: which of a big graph's edges are drawn.
- :mod:`app.ui.scoped`: a view drawn under a root node, for everyone or one browser.
- :mod:`app.ui.text`: text from outside shown as text, never as markup.
"""
