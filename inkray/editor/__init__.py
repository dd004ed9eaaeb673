"""``inkray edit``: annotate a drawing in the browser with live depth and relief previews.

Layers: :mod:`inkray.editor.session` (the document, its chain and previews),
:mod:`inkray.editor.app` (the HTTP API and the page), :mod:`inkray.editor.server`
(uvicorn on loopback). The page lives in ``static/`` with a vendored three.js.
"""
