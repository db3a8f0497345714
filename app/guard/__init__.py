"""Browsers are not trusted: what one may send, when its callbacks run, whether it may edit.

- :mod:`app.guard.door`: what a browser may send, checked before viser reads it.
- :mod:`app.guard.fair`: the fair callback pool (the presenter first, every other browser
  in its turn).
- :mod:`app.guard.gate`: a controller seen through a gate that refuses watchers' edits.

Text from outside is escaped by :mod:`app.ui.text`.
"""
