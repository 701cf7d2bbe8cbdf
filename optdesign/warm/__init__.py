"""The warm server: commands that start with their libraries already imported.

A command spends most of its wall time before and after its own work: the interpreter and
its imports (NumPy, CasADi, SciPy, matplotlib: a second for ``solve``) and the figures' first
font lookups. Only the work itself depends on the command; the imports are the same every
time. So the first ``optdesign`` command of a session runs as it always did and, as it exits,
starts a server in the background that imports every library once and then waits on a Unix
socket. Every later command is a small client: it hands the server its argument list, its
environment, working folder, umask, resource limits and its standard input, output and
error (the file descriptors themselves); the server forks a child from its warm memory, and
that child runs the command exactly as the program would, writing straight to the client's
terminal or pipes. The client forwards Ctrl-C and the other signals to the child's process
group and exits with the child's exit code.

* :mod:`optdesign.warm.place`: where the socket is (a folder only this user can enter) and the
  fingerprint that ties a server to one installation, its sources and its environment;
* :mod:`optdesign.warm.client`: the program's side (hand over, wait, forward signals; start a
  server after a command that found none);
* :mod:`optdesign.warm.server`: the server (import, listen, fork one child per command, report
  its exit, end when idle);
* :mod:`optdesign.warm.child`: the forked child taking on the client's process state.

``OPTDESIGN_SERVER=off`` runs every command in its own process and starts no server; ``optdesign
server status|start|stop`` shows, starts and stops it (docs/warm-server.md).
"""
