"""The editor's HTTP API and page, an ASGI application (Starlette).

Endpoints (a public contract, see ``docs/editor.md``):

- ``GET /`` the page; ``/static/...`` its scripts, styles and the vendored three.js;
- ``GET /api/info`` the file, the drawing's size, the label colours, the generation;
- ``GET /api/drawing.png`` the drawing;
- ``GET /api/annotations`` the current document; ``PUT`` replaces it
  (400 ``{"error": ...}`` and nothing changed when it is bad);
- ``POST /api/save`` writes the file, ``{"path": ...}``;
- ``GET /api/preview/labels.png``, ``depth.png``, ``relief.glb`` the previews,
  with ``X-Inkray-Compute-Ms`` and ``X-Inkray-Generation``; 422 ``{"error",
  "paths"}`` when the document cannot be computed; ``depth.png?method=exact``
  the exact depth map, ``depth.png?quality=draft`` the fast one with its fill
  at half resolution (the first answer after an edit);
- ``GET /api/relations`` the user's and predicted relations and the warnings;
- ``POST /api/pose`` ``{"handles": [[x, y], ...], "to": [[x, y], ...], "scale": s}``:
  the posed drawing as PNG (Pose mode; ``scale`` optional, 0.05..1, a smaller
  picture while dragging), with ``X-Inkray-Compute-Ms``; ``POST
  /api/pose/save`` a pose file's JSON: written as ``<name>.pose.json`` beside
  the annotation, ``{"path": ...}``.
"""

import io
import sys
from pathlib import Path

import anyio
from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from inkray.editor.posing import PoseSession
from inkray.editor.session import PREVIEWS, entry_paths
from inkray.errors import InkrayError, InputError

__all__ = ["editor_app", "LOOPBACK_HOSTS"]

#: The names of this machine a browser uses for a server on loopback.
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")

STATIC = Path(__file__).resolve().parent / "static"
_MAX_BODY = 64 * 1024 * 1024  # the annotation file's own byte limit is checked when decoding


def editor_app(session, *, allowed_hosts=None):
    """The ASGI application of an editing session.

    Parameters
    ----------
    session : inkray.editor.session.EditSession
    allowed_hosts : sequence of str, optional
        Host names the requests must name (their ``Host`` header), e.g.
        :data:`LOOPBACK_HOSTS`: a web page whose name was made to resolve to
        127.0.0.1 (DNS rebinding) then cannot reach the API. Default: any.

    Returns
    -------
    starlette.applications.Starlette

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from inkray.editor.session import EditSession
    >>> from inkray.examples import example_path
    >>> new = pathlib.Path(tempfile.mkdtemp()) / "t.inkray.json"
    >>> s = EditSession(new, drawing=example_path("turtle").parent / "drawing.png")
    >>> [route.path for route in editor_app(s).routes][:4]
    ['/', '/api/info', '/api/drawing.png', '/api/annotations']
    """
    drawing_png = _png(session.drawing.rgb)
    posing = PoseSession(session)

    async def page(request):
        return FileResponse(STATIC / "index.html", headers=_NO_STORE)

    async def info(request):
        return JSONResponse({"path": str(session.path), "autosave": str(session.autosave),
                             "drawing": session.document.get("drawing"),
                             "size": list(session.drawing.size), "palette": session.palette,
                             "generation": session.generation, "saved": session.saved,
                             "restored": session.restored}, headers=_NO_STORE)

    async def drawing(request):
        return Response(drawing_png, media_type="image/png")

    async def annotations(request):
        if request.method == "PUT":
            raw = await request.body()
            if len(raw) > _MAX_BODY:
                return _error(413, f"{session.path.name}: the document is larger than "
                                   f"{_MAX_BODY} bytes")
            try:
                generation = await anyio.to_thread.run_sync(session.replace, raw)
            except InputError as e:
                return _error(400, str(e))
            return JSONResponse({"generation": generation, "palette": session.palette},
                                headers=_NO_STORE)
        return JSONResponse(session.document, headers=dict(
            _NO_STORE, **{"X-Inkray-Generation": str(session.generation)}))

    async def save(request):
        try:
            path = await anyio.to_thread.run_sync(session.save)
        except OSError as e:
            return _error(500, f"{session.path}: cannot write ({e.strerror or e})")
        return JSONResponse({"path": str(path)})

    async def preview(request):
        name = request.path_params["name"]
        if name not in PREVIEWS:
            return _error(404, f"no preview {name!r} (expected one of {', '.join(PREVIEWS)})")
        method = request.query_params.get("method", "fast")
        if method not in ("fast", "exact"):
            return _error(400, f"method: unknown depth method {method!r} (expected fast, exact)")
        quality = request.query_params.get("quality", "full")
        if quality not in ("full", "draft"):
            return _error(400, f"quality: unknown quality {quality!r} (expected full, draft)")
        if quality == "draft" and method == "exact":
            return _error(400, "quality: a draft is of the fast method only (method=fast)")
        try:
            p = await anyio.to_thread.run_sync(lambda: session.preview(
                name, exact=method == "exact", draft=quality == "draft"))
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        return Response(p.body, media_type=p.media_type, headers=dict(_NO_STORE, **{
            "X-Inkray-Compute-Ms": f"{p.compute_ms:.1f}",
            "X-Inkray-Generation": str(p.generation)}))

    async def relations(request):
        try:
            value = await anyio.to_thread.run_sync(session.relations)
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        compute_ms = value.pop("compute_ms")
        return JSONResponse(value, headers=dict(_NO_STORE, **{
            "X-Inkray-Compute-Ms": f"{compute_ms:.1f}",
            "X-Inkray-Generation": str(value["generation"])}))

    async def pose(request):
        body = await _json(request)
        if not isinstance(body, dict) or not {"handles", "to"} <= set(body) <= {
                "handles", "to", "scale"}:
            return _error(400, "expected {\"handles\": [[x, y], ...], \"to\": [[x, y], ...], "
                               "\"scale\": s (optional)}")
        try:
            png, ms, generation = await anyio.to_thread.run_sync(lambda: posing.picture(
                body["handles"], body["to"], scale=body.get("scale", 1.0)))
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        return Response(png, media_type="image/png", headers=dict(_NO_STORE, **{
            "X-Inkray-Compute-Ms": f"{ms:.1f}", "X-Inkray-Generation": str(generation)}))

    async def pose_save(request):
        body = await _json(request)
        try:
            path = await anyio.to_thread.run_sync(posing.save, body)
        except InputError as e:
            return _error(400, str(e))
        except OSError as e:
            return _error(500, f"cannot write the pose file ({e.strerror or e})")
        return JSONResponse({"path": str(path)})

    routes = [
        Route("/", page),
        Route("/api/info", info),
        Route("/api/drawing.png", drawing),
        Route("/api/annotations", annotations, methods=["GET", "PUT"]),
        Route("/api/save", save, methods=["POST"]),
        Route("/api/preview/{name}", preview),
        Route("/api/relations", relations),
        Route("/api/pose", pose, methods=["POST"]),
        Route("/api/pose/save", pose_save, methods=["POST"]),
        Mount("/static", StaticFiles(directory=STATIC), name="static"),
    ]
    middleware = []
    if allowed_hosts is not None:
        middleware.append(Middleware(TrustedHostMiddleware, allowed_hosts=list(allowed_hosts)))
    return Starlette(routes=routes, middleware=middleware)


_NO_STORE = {"Cache-Control": "no-store"}


def _error(status, message):
    return JSONResponse({"error": message, "paths": entry_paths(message)}, status_code=status,
                        headers=_NO_STORE)


async def _json(request):
    import json

    raw = await request.body()
    if len(raw) > _MAX_BODY:
        return None
    try:
        return json.loads(raw)
    except ValueError:
        return None


def _failure(e):
    """422 for a document that cannot be computed, 500 for anything else; one line, as the CLI."""
    if isinstance(e, InputError):
        return _error(422, str(e))
    if isinstance(e, InkrayError):
        message = " ".join(str(e).split())
    elif isinstance(e, MemoryError):
        message = "out of memory (try a smaller drawing)"
    else:
        message = f"internal error: {type(e).__name__}: {' '.join(str(e).split())}"
    print(f"inkray edit: error: {message}", file=sys.stderr)
    return _error(500, message)


def _png(rgb):
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="PNG")
    return buf.getvalue()
