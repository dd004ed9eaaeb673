"""A real editor server (uvicorn on a free loopback port) in a thread, and HTTP calls to it."""

import json
import shutil
import socket
import threading
import time
import urllib.error
import urllib.request
from contextlib import contextmanager
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def copy_example(name, folder):
    """Copy a bundled drawing and its annotation into ``folder``; the annotation's path."""
    for p in (EXAMPLES / name).iterdir():
        if p.name.startswith("drawing"):
            shutil.copy(p, folder / p.name)
    return folder / "drawing.inkray.json"


@contextmanager
def running(session):
    """Serve ``session`` on 127.0.0.1 (a free port) while the block runs; yields the base URL."""
    import uvicorn

    from inkray.editor.app import LOOPBACK_HOSTS, editor_app

    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(64)
    server = uvicorn.Server(uvicorn.Config(editor_app(session, allowed_hosts=LOOPBACK_HOSTS),
                                           log_level="warning", lifespan="off"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + 20
    while not server.started:
        assert time.monotonic() < deadline, "the editor server did not start"
        time.sleep(0.01)
    try:
        yield f"http://127.0.0.1:{sock.getsockname()[1]}"
    finally:
        server.should_exit = True
        thread.join(10)
        sock.close()


def call(url, method="GET", body=None, headers=None):
    """``(status, headers, body bytes)`` of one request; ``body`` a dict is sent as JSON."""
    if isinstance(body, (dict, list)):
        body = json.dumps(body).encode()
    elif isinstance(body, str):
        body = body.encode()
    request = urllib.request.Request(url, data=body, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=120) as r:
            return r.status, r.headers, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers, e.read()
