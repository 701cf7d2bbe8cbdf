"""What a first user trips over at the command line: a YAML mistake named with the parser's
line, column and reason in one line, and ``--debug`` taken before or after the command."""
from optdesign.cli import main

BAD_INDENT = "name: x\nmechanism: fourbar_converter\ndesign:\n  l0: 1\n l1: 2\n"


def test_a_yaml_mistake_names_line_column_and_the_parser_s_reason(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(BAD_INDENT)
    assert main(["analyze", str(path)]) == 2
    err = capsys.readouterr().err
    assert err == ("optdesign: bad.yaml: not valid YAML at line 5, column 2: expected <block "
                   "end>, but found '<block mapping start>'\n")


def test_debug_is_taken_before_and_after_the_command(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(BAD_INDENT)
    for argv in (["--debug", "analyze", str(path)], ["analyze", str(path), "--debug"]):
        assert main(argv) == 2
        assert "Traceback" in capsys.readouterr().err
    assert main(["analyze", str(path)]) == 2
    assert "Traceback" not in capsys.readouterr().err
