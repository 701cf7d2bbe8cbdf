"""``--scheduler`` at an address where something else answers: an HTTP server, a server that
sends garbage, nothing at all. Each is exit 2 with one line within the one deadline, through
the command line and through the API, never a hang or a read that exhausts memory
(optdesign.fronts.cluster); a real scheduler still passes the same check."""
import http.server
import socket
import threading
import time

import pytest
import yaml

from optdesign.cli import main
from optdesign.errors import UsageError

from .conftest import small

distributed = pytest.importorskip("distributed")


@pytest.fixture
def problem_file(tmp_path):
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(small(points=3)))
    return path


@pytest.fixture
def http_server():
    server = http.server.HTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


@pytest.fixture
def garbage_server():
    """Sends bytes that frame a message of 2**63 frames, then keeps talking."""
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(4)
    stop = threading.Event()

    def serve():
        listener.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except OSError:
                continue
            try:
                conn.sendall(b"\xff" * 4096)
            except OSError:
                pass
            conn.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    stop.set()
    thread.join(timeout=5)
    listener.close()


@pytest.mark.parametrize("server", ["http_server", "garbage_server"])
def test_something_else_at_the_address_is_exit_2_at_once(server, problem_file, tmp_path,
                                                         capsys, request):
    address = request.getfixturevalue(server)
    t0 = time.monotonic()
    code = main(["pareto", str(problem_file), "--out", str(tmp_path / "o"),
                 "--scheduler", address])
    took = time.monotonic() - t0
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert "not a Dask scheduler at 127.0.0.1:" in err
    assert took < 20                   # the deadline is 3 s: far from the 90 s hang it was


def test_the_api_checks_the_scheduler_as_the_command_line_does(http_server, problem_file):
    from optdesign import api
    with pytest.raises(UsageError, match="not a Dask scheduler"):
        api.pareto(str(problem_file), scheduler=http_server)


def test_a_closed_port_and_a_malformed_address_are_named(problem_file, tmp_path, capsys):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]              # closed once the block ends
    assert main(["pareto", str(problem_file), "--out", str(tmp_path / "o"),
                 "--scheduler", f"tcp://127.0.0.1:{port}"]) == 2
    assert "no scheduler answered" in capsys.readouterr().err
    assert main(["pareto", str(problem_file), "--out", str(tmp_path / "o"),
                 "--scheduler", "tcp://127.0.0.1:notaport"]) == 2
    assert "malformed address" in capsys.readouterr().err


def test_a_real_scheduler_passes_the_check():
    from optdesign.fronts.cluster import connect
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        client = connect(cluster.scheduler_address)
        try:
            assert client.scheduler_info()["type"] == "Scheduler"
        finally:
            client.close()
