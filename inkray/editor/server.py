"""Serving the editor: a uvicorn server on loopback, the address printed, the browser opened."""

import ipaddress
import socket
import sys
import threading
import webbrowser

from inkray.editor.app import LOOPBACK_HOSTS, editor_app
from inkray.errors import InputError

__all__ = ["serve", "is_loopback"]


def is_loopback(host):
    """Whether ``host`` names this machine only (``127.0.0.1``, ``::1``, ``localhost``).

    Examples
    --------
    >>> is_loopback("127.0.0.1"), is_loopback("0.0.0.0")
    (True, False)
    """
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def serve(session, *, host="127.0.0.1", port=8765, open_browser=True, stream=None):
    """Serve ``session`` until interrupted (Ctrl-C stops it cleanly).

    Prints ``inkray edit: serving http://HOST:PORT/`` once the socket listens.

    Parameters
    ----------
    session : inkray.editor.session.EditSession
    host : str, default "127.0.0.1"
        Any other address than loopback prints a warning: whoever reaches it
        can read the drawing and rewrite the annotation file. On loopback,
        requests must name this machine (``Host: 127.0.0.1``, ``localhost``).
    port : int, default 8765
        0 picks a free port.
    open_browser : bool, default True
    stream : file, optional
        Where the address goes (default stdout); warnings go to stderr.

    Raises
    ------
    InputError
        The address cannot be bound.
    """
    import uvicorn

    stream = stream if stream is not None else sys.stdout
    if not 0 <= port <= 65535:
        raise InputError(f"--port {port}: expected 0..65535")
    if not is_loopback(host):
        print(f"inkray edit: warning: serving on {host}, not loopback: anyone who can reach it "
              f"can read the drawing and rewrite {session.path}", file=sys.stderr)
    sock = _listen(host, port)
    bound = sock.getsockname()[1]
    shown = f"[{host}]" if ":" in host else host
    url = f"http://{shown}:{bound}/"
    print(f"inkray edit: serving {url}", file=stream, flush=True)
    if open_browser:
        threading.Thread(target=webbrowser.open, args=(url,), daemon=True).start()
    hosts = LOOPBACK_HOSTS if is_loopback(host) else None
    config = uvicorn.Config(editor_app(session, allowed_hosts=hosts), log_level="warning",
                            lifespan="off",
                            timeout_graceful_shutdown=2)
    try:
        uvicorn.Server(config).run(sockets=[sock])
    finally:
        session.close()  # work still under way stops at its next stage
        sock.close()


def _listen(host, port):
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    # IPPROTO_TCP named: asyncio turns Nagle's algorithm off only on sockets that name it,
    # and an answer's body held back until its headers are acknowledged waits 40 ms for
    # the client's delayed ACK on every request of a kept-alive connection
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as e:
        sock.close()
        raise InputError(f"--host {host} --port {port}: cannot listen there "
                         f"({e.strerror or e})") from None
    sock.listen(128)
    return sock
