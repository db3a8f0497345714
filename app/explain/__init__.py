"""Explain mode in the app: step through a method as the chapter does.

- :mod:`app.explain.panel`: the Explain panel and its thread (:class:`Explainer`).
- :mod:`app.explain.view`: one step drawn in the 3-D scene.

Pictures of the steps for slides are :mod:`app.media.explain_pictures`.
"""
