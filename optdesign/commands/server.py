"""``optdesign server status|start|stop [--json]``: the warm server of this installation.

The server imports the libraries once and runs every later command in a process forked from
it (:mod:`optdesign.warm`; docs/warm-server.md). A command that finds none starts one as it
exits; ``start`` starts one now and waits until it listens, ``stop`` ends it (the commands it
is running finish), ``status`` says whether one listens and whether it serves this
installation as it is now. Exit 0; 1 when ``start`` finds no server listening after
:data:`START_TIMEOUT_S`; 2 when ``OPTDESIGN_SERVER=off`` forbids ``start``.
"""
from __future__ import annotations

#: seconds ``start`` waits for the server to listen (it imports every library first)
START_TIMEOUT_S = 120.0


def add_parser(sub) -> None:
    p = sub.add_parser("server", help="the warm server that keeps the libraries imported "
                                      "between commands: status, start, stop")
    p.add_argument("action", choices=("status", "start", "stop"))
    p.add_argument("--json", action="store_true", help="print the state as JSON")
    p.set_defaults(run=run)


def run(args) -> int:
    import time

    from optdesign.errors import OptDesignError, UsageError
    from optdesign.warm import client, place

    env = client.program_environment()
    state = client.ask("status", env)
    if args.action == "start" and not _current(state, env):
        if not place.enabled(env):
            raise UsageError(f"{place.VARIABLE}=off: no warm server is started")
        if state is not None:
            client.ask("stop", env)             # stale: it makes way for the new one
        if client.start_server(env) is None:
            raise OptDesignError(f"no warm server can start: its socket's folder "
                                 f"{place.folder(env)} must be a folder of this user that no "
                                 f"one else may enter (mode 0700, not a link), and the "
                                 f"socket's path at most 107 bytes long")
        deadline = time.monotonic() + START_TIMEOUT_S
        while not _current(state := client.ask("status", env), env):
            if time.monotonic() > deadline:
                raise OptDesignError(f"the warm server did not listen within "
                                     f"{START_TIMEOUT_S:g} s")
            time.sleep(0.1)
    elif args.action == "stop" and state is not None:
        client.ask("stop", env)
    _report(args, state, env)
    return 0


def _current(state: dict | None, env: dict) -> bool:
    """True when ``state`` is a server that runs this installation's commands."""
    from optdesign.warm import place
    return state is not None and state.get("fingerprint") == place.fingerprint(env)


def _report(args, state: dict | None, env: dict) -> None:
    import time

    from optdesign.warm import place

    path = place.socket_path(env)
    shown = {"socket": str(path) if path else None, "running": False}
    if state is not None and args.action != "stop":
        shown |= {"running": True, "pid": state["pid"], "current": _current(state, env),
                  "up_s": round(time.time() - state["started"], 1),
                  "idle_limit_s": state["idle_s"],
                  "commands_running": state["commands_running"]}
    elif state is not None:
        shown |= {"stopped_pid": state["pid"]}
    if args.json:
        from optdesign.outputs.atomic import json_text
        print(json_text(shown))
    elif shown["running"]:
        print(f"warm server pid {shown['pid']}, up {shown['up_s']:g} s, "
              f"{shown['commands_running']} command(s) running, ends after "
              f"{shown['idle_limit_s']:g} s idle; socket {shown['socket']}"
              + ("" if shown["current"] else
                 " (stale: the installation changed; it ends at the next command)"))
    elif "stopped_pid" in shown:
        print(f"warm server pid {shown['stopped_pid']} stopped (the commands it runs finish)")
    else:
        print(f"no warm server (socket {shown['socket']})")
