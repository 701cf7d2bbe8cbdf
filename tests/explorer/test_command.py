"""``optdesign explore``'s bad input: one line naming what is wrong, exit 2, before anything
is served."""
import socket

import pytest

from tests.conftest import ROOT, run_main

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"


def test_a_port_in_use_is_one_line(capsys):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code, _ = run_main(["explore", DISC, "--no-browser", "--port", port])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert f"--port {port}: 127.0.0.1:{port} is in use by another program" in err


@pytest.mark.parametrize("argv, message", [
    (["--port", "0"], "--port must lie in [1, 65535] (got 0)"),
    (["--design", "/no/such/result.json"], "--design '/no/such/result.json': no such file"),
    (["--front", "/no/such/folder"], "--front '/no/such/folder': has no pareto.csv"),
    (["--point", "2"], "--point picks a point of a front"),
])
def test_bad_options_are_one_line(argv, message, capsys):
    code, _ = run_main(["explore", DISC, "--no-browser", *argv])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and message in err, err


def test_a_file_that_fails_to_load_is_one_line(write_problem, capsys):
    path = write_problem({"name": "x", "mechanism": "fourbar_converter"})
    code, _ = run_main(["explore", path, "--no-browser"])
    err = capsys.readouterr().err
    assert code == 2 and err == "optdesign: p.yaml: input_speed is required (crank speed " \
                                "ω1, rad/s)\n"


def test_explore_is_never_handed_to_the_warm_server():
    from optdesign.warm import client

    assert "explore" in client._LOCAL
