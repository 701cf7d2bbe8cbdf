"""``optdesign explore PROBLEM.yaml [--design FILE [--point K | --knee]] [--front DIR]
[--port N] [--no-browser]``: the explorer's page served on 127.0.0.1.

The problem, the design and the front are read before anything is served, by the rules of
every command (a fault is one line naming the file and key, exit 2); so is the port (in use,
or out of range: exit 2). Then the URL is printed, the browser opened unless
``--no-browser``, and the page served until Ctrl-C (exit 0). Each browser tab gets a session
of its own (:class:`optdesign.explorer.session.Session`); the NLPs built for re-optimising are
shared. The page's scripts are served by this server itself: nothing is fetched from the
internet.
"""
from __future__ import annotations

import errno
import socket
import sys

from optdesign.errors import UsageError

#: where the page is served: this machine only
HOST = "127.0.0.1"


def add_parser(sub) -> None:
    from optdesign.commands.design_source import add_arguments

    p = sub.add_parser("explore", help="a live page: drag a length or a bound, watch the "
                                       "linkage, its speeds, δ and the optimum move")
    p.add_argument("problem", help="problem file (YAML)")
    add_arguments(p)
    p.add_argument("--front", metavar="DIR",
                   help="the folder of a finished optdesign pareto run: its points drawn, "
                        "a click loads one")
    p.add_argument("--port", type=int, metavar="N",
                   help="serve on this port of 127.0.0.1 (default: a free one)")
    p.add_argument("--no-browser", action="store_true",
                   help="print the URL only, open no browser")
    p.set_defaults(run=run)


def run(args) -> int:
    from optdesign.commands.design_source import chosen_design
    from optdesign.explorer.front import front_points
    from optdesign.explorer.session import Session

    session = Session.open(args.problem)
    chosen = chosen_design(args, session.problem, one_count=False)
    if chosen.values is not None:
        session.load(chosen.values)
        session.source = chosen.source
    front = front_points(args.front, session.problem) if args.front is not None else None
    port = free_port(args.port)
    session.prepare()               # the NLP of the count on screen, before the first click
    return serve(session, front, port, browser=not args.no_browser)


def free_port(port: int | None) -> int:
    """``port`` when 127.0.0.1 can listen on it, or a free one for None; UsageError for a
    port in use or out of range."""
    if port is not None and not 1 <= port <= 65535:
        raise UsageError(f"--port must lie in [1, 65535] (got {port})")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        try:
            probe.bind((HOST, port or 0))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise UsageError(f"--port {port}: {HOST}:{port} is in use by another "
                                 f"program; choose another port, or leave --port out for a "
                                 f"free one") from None
            raise UsageError(f"--port {port}: cannot listen on {HOST}:{port} "
                             f"({exc.strerror})") from None
        return probe.getsockname()[1]


def serve(session, front, port: int, browser: bool = True) -> int:
    """Serve the page of ``session`` (a fork of it per browser tab) on ``HOST:port`` until
    Ctrl-C."""
    import panel as pn

    from optdesign.explorer.page import Page
    from optdesign.explorer.widgets import send_at_once

    def app():
        doc = pn.state.curdoc
        pn.state.onload(lambda: send_at_once(doc))     # before the first move's reply
        return Page(session.fork(), front).layout

    url = f"http://{HOST}:{port}/"
    server = pn.serve({"/": app}, port=port, address=HOST, show=False, start=False,
                      websocket_origin=[f"{HOST}:{port}", f"localhost:{port}"],
                      title=f"optdesign explore: {session.problem.name}", verbose=False)
    print(f"optdesign explore: {session.problem.name} served at {url} (Ctrl-C ends it)",
          flush=True)
    if browser:
        import webbrowser

        webbrowser.open(url)
    try:
        server.io_loop.start()
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    print("optdesign explore: stopped", file=sys.stderr, flush=True)
    return 0
