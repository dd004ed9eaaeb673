"""The editor's HTTP API and page, an ASGI application (Starlette).

Endpoints (a public contract, see ``docs/editor.md``):

- ``GET /`` the page; ``/static/...`` its scripts, styles and the vendored three.js;
- ``GET /api/info`` the file, the drawing's size, the label colours, the generation;
- ``GET /api/drawing.png`` the drawing;
- ``GET /api/annotations`` the current document; ``PUT`` replaces it
  (400 ``{"error": ...}`` and nothing changed when it is bad);
- ``POST /api/save`` writes the file, ``{"path": ...}`` (422 and nothing written for a
  document ``inkray validate`` refuses);
- ``POST /api/discard-autosave`` drops the autosave and goes back to the file;
- ``POST /api/outline-path`` ``{"from", "to"}``: a boundary path along the nearest
  region outline between two points;
- ``POST /api/scribble-region`` ``{"points", "current"}``: the region a region
  scribble extends (None: a new one);
- ``GET /api/preview/labels.png``, ``depth.png``, ``relief.glb`` the previews,
  with ``X-Inkray-Compute-Ms`` and ``X-Inkray-Generation``; 422 ``{"error",
  "paths"}`` when the document cannot be computed; ``depth.png?method=exact``
  the exact depth map, ``depth.png?quality=draft`` the fast one with its fill
  at half resolution (the first answer after an edit); a depth map's
  ``X-Inkray-Quality`` is ``draft`` or ``full`` (a draft request answered by
  the full map, as on opening: the full request would give the same bytes);
- ``GET /api/relations`` the user's and predicted relations and the warnings;
- ``GET /api/shot`` the shot being stepped through (``inkray edit FRAME.png``):
  its frames, keys, the current frame and its entries to check (404 when the
  session edits one file); ``POST /api/shot/open`` ``{"frame"}`` edits that
  frame instead (see :mod:`inkray.editor.shot`).
- ``POST /api/pose`` ``{"handles": [[x, y], ...], "to": [[x, y], ...], "scale": s}``:
  the posed drawing as PNG (Pose mode; ``scale`` optional, 0.05..1, a smaller
  picture while dragging), with ``X-Inkray-Compute-Ms``; ``POST
  /api/pose/save`` a pose file's JSON: written as ``<name>.pose.json`` beside
  the annotation, ``{"path": ...}``.
- ``GET /api/pose/meshes`` the parts as textured meshes, back to front (JSON,
  see :meth:`inkray.editor.posing.PoseSession.meshes`); ``POST
  /api/pose/vertices`` ``{"handles", "to"}`` their posed vertices, float32
  ``x, y, height`` per vertex in that order: what the page draws while a
  handle moves. Both carry ``X-Inkray-Generation``: vertices of another
  generation than the meshes' call for the meshes again.
"""

import io
import json
import sys
from pathlib import Path

import anyio
import numpy as np
from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from inkray.editor.posing import PoseSession
from inkray.editor.session import PREVIEWS, entry_paths
from inkray.errors import InkrayError, InputError
from inkray.input.limits import DEFAULT_LIMITS

__all__ = ["editor_app", "LOOPBACK_HOSTS"]

#: The names of this machine a browser uses for a server on loopback.
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")

STATIC = Path(__file__).resolve().parent / "static"
_MAX_BODY = DEFAULT_LIMITS.file_bytes  # the annotation file's own limit
_MAX_POINTS_BODY = 1024 * 1024  # a click pair or one scribble


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
    drawing_png = {}  # the drawing's PNG, made again when a shot's next frame is opened
    posing = PoseSession(session)

    async def page(request):
        return FileResponse(STATIC / "index.html", headers=_NO_STORE)

    async def info(request):
        return JSONResponse({"path": str(session.path), "autosave": str(session.autosave),
                             "drawing": session.document.get("drawing"),
                             "size": list(session.drawing.size), "palette": session.palette,
                             "generation": session.generation, "saved": session.saved,
                             "restored": session.restored, "exists": session.path.exists()},
                            headers=_NO_STORE)

    async def drawing(request):
        shown = session.drawing
        if drawing_png.get("of") is not shown:
            drawing_png.update(of=shown, png=_png(shown.rgb))
        return Response(drawing_png["png"], media_type="image/png", headers=_NO_STORE)

    async def annotations(request):
        if request.method == "PUT":
            raw = await _body(request, _MAX_BODY)
            if raw is None:
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
        except InputError as e:
            return _error(422, str(e), session)
        except OSError as e:
            return _error(500, f"{session.path}: cannot write ({e.strerror or e})")
        return JSONResponse({"path": str(path)})

    async def discard(request):
        generation = await anyio.to_thread.run_sync(session.discard)
        return JSONResponse({"generation": generation, "palette": session.palette},
                            headers=_NO_STORE)

    async def points_of(request, keys):
        """The JSON body's points ``keys``, each ``[x, y]`` (a list of them for ``points``)."""
        raw = await _body(request, _MAX_POINTS_BODY)
        if raw is None:
            raise InputError(f"the request is larger than {_MAX_POINTS_BODY} bytes")
        try:
            body = json.loads(raw)
            out = []
            for key in keys:
                value = np.asarray(body[key], float)
                if value.ndim not in (1, 2) or value.shape[-1] != 2 or not value.size \
                        or not np.isfinite(value).all():
                    raise ValueError
                out.append(value.reshape(-1, 2) if key == "points" else value)
            return out, body
        except (ValueError, TypeError, KeyError, AttributeError):
            raise InputError(f"expected a JSON object with {', '.join(keys)} as [x, y] points")

    async def outline_path(request):
        try:
            (start, end), _ = await points_of(request, ("from", "to"))
            value = await anyio.to_thread.run_sync(session.outline_path, start, end)
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        value.pop("compute_ms")
        return JSONResponse(value, headers=_NO_STORE)

    async def scribble_region(request):
        try:
            (points,), body = await points_of(request, ("points",))
            current = body.get("current")
            current = current if isinstance(current, int) else None
            region, edge = await anyio.to_thread.run_sync(
                lambda: (session.scribble_region(points, current=current),
                         session.on_edge(points)))
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        return JSONResponse({"region": region, "edge": edge}, headers=_NO_STORE)

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
            return _failure(e, session)
        headers = {"X-Inkray-Compute-Ms": f"{p.compute_ms:.1f}",
                   "X-Inkray-Generation": str(p.generation)}
        if name == "depth.png":
            headers["X-Inkray-Quality"] = "draft" if p.draft else "full"
        return Response(p.body, media_type=p.media_type, headers=dict(_NO_STORE, **headers))

    async def relations(request):
        try:
            value = await anyio.to_thread.run_sync(session.relations)
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        value["plain"] = session.explain(value["error"]) if value["error"] else None
        return _computed(value)

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

    async def pose_meshes(request):
        try:
            value = await anyio.to_thread.run_sync(posing.meshes)
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        return _computed(value)

    async def pose_vertices(request):
        body = await _json(request)
        if not isinstance(body, dict) or set(body) != {"handles", "to"}:
            return _error(400, "expected {\"handles\": [[x, y], ...], \"to\": [[x, y], ...]}")
        try:
            data, ms, generation = await anyio.to_thread.run_sync(
                lambda: posing.vertices(body["handles"], body["to"]))
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        return Response(data, media_type="application/octet-stream", headers=dict(_NO_STORE, **{
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
        Route("/api/discard-autosave", discard, methods=["POST"]),
        Route("/api/outline-path", outline_path, methods=["POST"]),
        Route("/api/scribble-region", scribble_region, methods=["POST"]),
        Route("/api/preview/{name}", preview),
        Route("/api/relations", relations),
        *_shot_routes(session),
        Route("/api/pose", pose, methods=["POST"]),
        Route("/api/pose/save", pose_save, methods=["POST"]),
        Route("/api/pose/meshes", pose_meshes),
        Route("/api/pose/vertices", pose_vertices, methods=["POST"]),
        Mount("/static", StaticFiles(directory=STATIC), name="static"),
    ]
    middleware = []
    if allowed_hosts is not None:
        middleware.append(Middleware(TrustedHostMiddleware, allowed_hosts=list(allowed_hosts)))
    return Starlette(routes=routes, middleware=middleware)


_NO_STORE = {"Cache-Control": "no-store"}


async def _body(request, limit):
    """The request's body, read as it streams in; None as soon as it exceeds ``limit`` bytes
    (so a huge or endless body costs at most ``limit`` bytes of memory)."""
    length = request.headers.get("content-length", "")
    if length.isdigit() and int(length) > limit:
        return None
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > limit:
            return None
    return bytes(body)


async def _json(request):
    """The request's JSON body (at most the annotation file's byte limit), or None."""
    import json

    raw = await _body(request, _MAX_BODY)
    if raw is None:
        return None
    try:
        return json.loads(raw)
    except ValueError:
        return None


def _error(status, message, session=None):
    """``{"error", "paths", "plain"}``: ``plain`` says a contradiction in plain words."""
    plain = session.explain(message) if session is not None else None
    return JSONResponse({"error": message, "paths": entry_paths(message), "plain": plain},
                        status_code=status, headers=_NO_STORE)


def _computed(value):
    """A value the session computed for the newest document (``generation`` and
    ``compute_ms`` among its keys) as JSON, its time and generation in headers."""
    compute_ms = value.pop("compute_ms")
    return JSONResponse(value, headers=dict(_NO_STORE, **{
        "X-Inkray-Compute-Ms": f"{compute_ms:.1f}",
        "X-Inkray-Generation": str(value["generation"])}))


def _failure(e, session=None):
    """422 for a document that cannot be computed, 500 for anything else; one line, as the CLI."""
    if isinstance(e, InputError):
        return _error(422, str(e), session)
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


def _shot_routes(session):
    """``GET /api/shot`` and ``POST /api/shot/open`` (:mod:`inkray.editor.shot`)."""

    async def shot(request):
        if session.shot is None:
            return _error(404, "not editing a shot (open a frame's drawing: inkray edit FRAME.png)")
        try:
            value = await anyio.to_thread.run_sync(session.shot.describe)
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        return JSONResponse(dict(value, generation=session.generation), headers=_NO_STORE)

    async def open_frame(request):
        if session.shot is None:
            return _error(404, "not editing a shot (open a frame's drawing: inkray edit FRAME.png)")
        raw = await _body(request, _MAX_POINTS_BODY)
        try:
            frame = json.loads(raw or b"null")["frame"]
            if not isinstance(frame, str):
                raise TypeError
        except (ValueError, TypeError, KeyError):
            return _error(400, 'expected a JSON object {"frame": NAME}')
        try:
            value = await anyio.to_thread.run_sync(session.shot.open, session, frame)
        except Exception as e:  # noqa: BLE001 - every failure is one line for the page
            return _failure(e)
        return JSONResponse(dict(value, generation=session.generation), headers=_NO_STORE)

    return [Route("/api/shot", shot), Route("/api/shot/open", open_frame, methods=["POST"])]
