"""Whatever lies beside an output folder is untrusted: planted links and manifests turn nothing
against the user (optdesign.outputs.folder, optdesign.outputs.checks, optdesign.fronts.store).

Each test plants one of the files a hostile neighbour (another user of a shared /tmp, or a
careless script) could leave, runs the real code on the folder, and checks that nothing
outside the folder was read, truncated, moved or deleted, and that the folder is as a run
leaves it.
"""
import json
import os
import stat
import threading
import time

import pytest
import yaml

from optdesign.cli import main
from optdesign.errors import ProblemError, UsageError
from optdesign.outputs.checks import prepare_out, resolve_out
from optdesign.outputs import folder as output_dir
from optdesign.outputs.folder import MARKER, OutputFolder
from optdesign.commands.files import SOLVE_FILES
from tests.conftest import ROOT

FREE_FILE = ROOT / "problems" / "sharkov2022_disc.yaml"
SECRET = "the user's own file\n"


def _write_set(text):
    def write(folder):
        return [folder.joinpath(n).write_text(f"{text} {n}") and folder / n for n in SOLVE_FILES]
    return write


@pytest.fixture
def victim(tmp_path):
    """A file of the user's outside any output folder."""
    path = tmp_path / "elsewhere" / "victim.txt"
    path.parent.mkdir()
    path.write_text(SECRET)
    return path


def _siblings(out):
    return sorted(p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}."))


# --------------------------------------------------------------------------- the lock
def test_a_lock_planted_as_a_link_is_refused_and_its_target_kept(tmp_path, victim):
    out = tmp_path / "out"
    (tmp_path / ".out.lock").symlink_to(victim)
    with pytest.raises(ProblemError, match="it is a link"):
        OutputFolder(out, SOLVE_FILES).acquire()
    assert victim.read_text() == SECRET
    assert (tmp_path / ".out.lock").is_symlink()          # left as it is


def test_a_lock_planted_as_a_hard_link_or_a_full_file_is_never_truncated(tmp_path, victim):
    out = tmp_path / "out"
    os.link(victim, tmp_path / ".out.lock")
    with pytest.raises(ProblemError, match="not an optdesign lock"):
        OutputFolder(out, SOLVE_FILES).acquire()
    assert victim.read_text() == SECRET
    (tmp_path / ".out.lock").unlink()
    (tmp_path / ".out.lock").write_text(SECRET * 10)       # more than a pid: not a lock
    with pytest.raises(ProblemError, match="not an optdesign lock"):
        OutputFolder(out, SOLVE_FILES).acquire()
    assert (tmp_path / ".out.lock").read_text() == SECRET * 10


def test_the_lock_goes_when_the_run_ends_and_a_killed_runs_lock_is_reused(tmp_path):
    out = tmp_path / "out"
    (tmp_path / ".out.lock").write_text("12345\n")          # what a kill -9 leaves
    with OutputFolder(out, SOLVE_FILES) as folder:
        assert (tmp_path / ".out.lock").read_text() == f"{os.getpid()}\n"
        folder.replace_with(_write_set("one"))
    assert _siblings(out) == []
    code = main(["solve", str(FREE_FILE), "--out", str(out), "--no-plots"])
    assert code == 0
    assert _siblings(out) == []


def test_a_run_waiting_on_the_lock_takes_the_new_one_when_the_holder_removes_it(
        tmp_path, monkeypatch):
    """The holder removes the lock file at its end; a second run that opened the old file
    meanwhile must not hold a lock on a name-less file while a third run takes the name."""
    out = tmp_path / "out"
    first = OutputFolder(out, SOLVE_FILES)
    first.acquire()
    second = OutputFolder(out, SOLVE_FILES)
    errors = []

    def wait_for_it():
        try:
            second.acquire()
        except Exception as exc:          # pragma: no cover - the failure is reported below
            errors.append(exc)

    waiter = threading.Thread(target=wait_for_it)
    waiter.start()
    time.sleep(0.3)                       # the second run is waiting on the first's file
    first.release()
    waiter.join(timeout=10)
    assert not errors
    lock = tmp_path / ".out.lock"
    assert os.fstat(second._lock_fd).st_ino == os.lstat(lock).st_ino   # holds the live name
    monkeypatch.setattr(output_dir, "LOCK_GRACE_S", 0.0)
    with pytest.raises(ProblemError, match=f"another optdesign run \\(pid {os.getpid()}\\)"):
        OutputFolder(out, SOLVE_FILES).acquire()
    second.release()
    assert not lock.exists()


# --------------------------------------------------------------------------- leftovers
def test_a_planted_manifest_naming_paths_outside_deletes_and_moves_nothing(
        tmp_path, victim, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    planted = tmp_path / ".out.commit-1-x"
    planted.mkdir()
    (planted / "evil.sh").write_text("rm -rf ~")
    (planted / "result.json").write_text("planted")
    for owned in ([str(victim)], [os.path.relpath(victim, out)], ["../elsewhere/victim.txt"],
                  ["result.json", "evil.sh"]):
        (planted / MARKER).write_text(json.dumps({"owned": owned, "files": ["evil.sh"]}))
        with OutputFolder(out, SOLVE_FILES):
            pass
        assert victim.read_text() == SECRET
        assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
        assert (planted / "evil.sh").exists() and (planted / "result.json").exists()
    assert "left" in capsys.readouterr().err


def test_leftovers_that_are_links_or_not_folders_are_never_followed(tmp_path, victim):
    out = tmp_path / "out"
    elsewhere = victim.parent
    # a "new" set that is a link to the user's folder: its files must not be moved in or
    # removed; an "old" set that is a link must not become the output folder
    (tmp_path / ".out.new-1-x").symlink_to(elsewhere, target_is_directory=True)
    (tmp_path / ".out.old-1-x").symlink_to(elsewhere, target_is_directory=True)
    (tmp_path / ".out.commit-1-x").symlink_to(elsewhere, target_is_directory=True)
    (elsewhere / MARKER).write_text(json.dumps({"owned": list(SOLVE_FILES),
                                                "files": ["result.json"]}))
    (elsewhere / "result.json").write_text("not a result")
    with OutputFolder(out, SOLVE_FILES) as folder:
        folder.replace_with(_write_set("mine"))
    assert not out.is_symlink() and out.is_dir()
    assert sorted(p.name for p in elsewhere.iterdir()) == sorted(
        [MARKER, "result.json", "victim.txt"])
    assert victim.read_text() == SECRET
    assert (out / "result.json").read_text() == "mine result.json"


def test_a_link_inside_a_leftover_is_not_moved_into_the_folder(tmp_path, victim):
    out = tmp_path / "out"
    out.mkdir()
    leftover = tmp_path / ".out.new-1-x"
    leftover.mkdir()
    (leftover / "notes.txt").symlink_to(victim)
    with OutputFolder(out, SOLVE_FILES):
        pass
    assert not (out / "notes.txt").exists() and not (out / "notes.txt").is_symlink()
    assert victim.read_text() == SECRET


# --------------------------------------------------------------------------- the folder
@pytest.mark.parametrize("atomic_exchange", [True, False])
@pytest.mark.parametrize("users_file", [False, True])
def test_the_folder_keeps_its_mode(tmp_path, monkeypatch, atomic_exchange, users_file):
    if not atomic_exchange:
        monkeypatch.setattr(output_dir, "_exchange", lambda a, b: False)
    out = tmp_path / "out"
    out.mkdir()
    os.chmod(out, 0o700)
    if users_file:                         # a folder of the user's is committed in place
        (out / "notes.txt").write_text("mine")
    for text in ("one", "two"):
        with OutputFolder(out, SOLVE_FILES) as folder:
            folder.replace_with(_write_set(text))
        assert stat.S_IMODE(out.stat().st_mode) == 0o700
    assert (out / "result.json").read_text() == "two result.json"


#: another user's cases need a link or a folder of another uid: only root can make one here
as_root = pytest.mark.skipif(os.geteuid() != 0, reason="planting another user's link or "
                             "folder needs root (os.lchown/os.chown to another uid)")
NOBODY = 65534


def _shared(tmp_path, name="shared"):
    """A sticky, world-writable folder, as /tmp is."""
    shared = tmp_path / name
    shared.mkdir()
    os.chmod(shared, 0o1777)
    return shared


def _plant(link, target, uid=NOBODY):
    link.symlink_to(target)
    os.lchown(link, uid, uid)


@as_root
@pytest.mark.parametrize("where", ["the folder's own name", "results, which the run makes"])
def test_another_users_link_in_a_shared_folder_is_not_followed(tmp_path, monkeypatch, capsys,
                                                               victim, where):
    """The kernel's protected-symlinks rule, whatever the machine's setting: a stranger's link
    in a sticky world-writable folder leads nowhere; nothing of the victim's is touched."""
    shared = _shared(tmp_path)
    monkeypatch.chdir(shared)
    if where == "results, which the run makes":
        _plant(shared / "results", victim.parent)
        planted = shared / "results"
    else:
        os.mkdir(shared / "results", 0o1777)
        os.chmod(shared / "results", 0o1777)
        _plant(shared / "results" / "sharkov2022_disc", victim.parent)
        planted = shared / "results" / "sharkov2022_disc"
    before = sorted(victim.parent.iterdir())
    assert main(["curves", str(ROOT / "problems" / "sharkov2022_disc.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{planted} is a link of another user (uid {NOBODY})" in err
    assert sorted(victim.parent.iterdir()) == before and victim.read_text() == SECRET
    with pytest.raises(UsageError, match="is a link of another user"):
        OutputFolder(shared / "results" / "sharkov2022_disc", SOLVE_FILES)


@as_root
def test_links_the_kernel_would_follow_are_followed(tmp_path, monkeypatch):
    """One's own link in a shared folder, and a stranger's in a folder that is not shared
    (only its owner could have put it there), lead where they point."""
    from optdesign.outputs.links import followed
    shared = _shared(tmp_path)
    target = tmp_path / "mine"
    target.mkdir()
    (shared / "own").symlink_to(target)
    assert resolve_out(str(shared / "own"), "p")[0] == shared / "own"
    assert prepare_out(str(shared / "own" / "x"), "p") == shared / "own" / "x"
    assert (target / "x").is_dir()
    private = tmp_path / "private"
    private.mkdir()
    _plant(private / "theirs", target)
    assert followed(private / "theirs", "--out") == str(target)
    _plant(shared / "owners", target, uid=NOBODY)     # the shared folder's owner's link
    os.chown(shared, NOBODY, NOBODY)
    assert followed(shared / "owners", "--out") == str(target)


def _xattrs_supported(path) -> bool:
    try:
        os.setxattr(path, "user.probe", b"1")
        os.removexattr(path, "user.probe")
        return True
    except OSError:
        return False


@as_root
@pytest.mark.parametrize("atomic_exchange", [True, False])
def test_a_replaced_folder_keeps_its_owner_group_mode_and_attributes(tmp_path, monkeypatch,
                                                                      atomic_exchange):
    """A team's folder (another owner, group, setgid 2770, an extended attribute) comes back
    as it was, and the set's files take the folder's group as a setgid folder gives it."""
    if not atomic_exchange:
        monkeypatch.setattr(output_dir, "_exchange", lambda a, b: False)
    out = tmp_path / "team"
    out.mkdir()
    os.chown(out, NOBODY, NOBODY)
    os.chmod(out, 0o2770)
    xattrs = _xattrs_supported(out)
    if xattrs:
        os.setxattr(out, "user.team", b"blue")
    for text in ("one", "two"):
        with OutputFolder(out, SOLVE_FILES) as folder:
            folder.replace_with(_write_set(text))
        st = out.stat()
        assert (st.st_uid, st.st_gid, stat.S_IMODE(st.st_mode)) == (NOBODY, NOBODY, 0o2770)
        assert (out / "result.json").stat().st_gid == NOBODY
        if xattrs:
            assert os.getxattr(out, "user.team") == b"blue"
    assert (out / "result.json").read_text() == "two result.json"


def test_a_folder_whose_attributes_cannot_be_given_is_written_in_place(tmp_path,
                                                                       monkeypatch):
    """Where the sibling cannot take the folder's attributes (another user's folder for a
    runner who is not root), the set goes into the folder itself, which keeps its own."""
    from optdesign.outputs.attributes import take_on
    out = tmp_path / "theirs"
    out.mkdir()
    staging = tmp_path / "staging"
    staging.mkdir()
    if os.geteuid() == 0:                   # a folder of another owner, chown refused
        os.chown(out, NOBODY, NOBODY)

        def refused(*args):
            raise PermissionError(1, "Operation not permitted")
        monkeypatch.setattr("optdesign.outputs.attributes.os.chown", refused)
        assert not take_on(out, staging)
        monkeypatch.undo()
    monkeypatch.setattr(output_dir, "take_on", lambda folder, staging: False)
    inode = out.stat().st_ino
    with OutputFolder(out, SOLVE_FILES) as folder:
        folder.replace_with(_write_set("one"))
    assert out.stat().st_ino == inode                       # the same folder, written into
    assert (out / "result.json").read_text() == "one result.json"
    assert _siblings(out) == []


def test_an_empty_out_is_refused_and_dot_dots_create_nothing_on_the_way(tmp_path,
                                                                         monkeypatch):
    monkeypatch.chdir(tmp_path)
    for empty in ("", "  "):
        with pytest.raises(UsageError, match="is not a folder name"):
            prepare_out(empty, "p")
    assert list(tmp_path.iterdir()) == []
    path = prepare_out("a/b/../../x", "p")
    assert path == type(path)("x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x"]
    assert resolve_out(str(tmp_path / "c" / ".." / "y"), "p")[0] == tmp_path / "y"
    assert resolve_out("../up", "p")[0] == type(path)("../up")      # a plain .. is kept


def test_solve_with_an_empty_out_is_exit_2_and_writes_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["solve", str(FREE_FILE), "--out", ""]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out" in err
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- the journal
@pytest.fixture
def small_problem(tmp_path):
    from tests.pareto.conftest import small
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(small(points=3)))
    return path


def test_resume_refuses_a_journal_that_is_a_link(tmp_path, small_problem, victim, capsys):
    out = tmp_path / "front"
    out.mkdir()
    (out / "points.jsonl").symlink_to(victim)
    assert main(["pareto", str(small_problem), "--out", str(out), "--resume",
                 "--workers", "1", "--no-report"]) == 2
    err = capsys.readouterr().err
    assert "points.jsonl" in err and "link" in err and err.count("\n") == 1
    assert victim.read_text() == SECRET
    assert (out / "points.jsonl").is_symlink()


@pytest.mark.parametrize("journal, command", [("points.jsonl", "pareto"),
                                              ("cells.jsonl", "atlas")])
def test_resume_refuses_a_journal_with_another_name(tmp_path, small_problem, victim, capsys,
                                                    journal, command):
    """A journal hard-linked to a file outside the folder would be appended to there."""
    out = tmp_path / "front"
    out.mkdir()
    os.link(victim, out / journal)
    problem = small_problem if command == "pareto" else ROOT / "problems" / "atlas_fourbar.yaml"
    assert main([command, str(problem), "--out", str(out), "--resume", "--workers", "1"]
                + (["--no-report"] if command == "pareto" else [])) == 2
    err = capsys.readouterr().err
    assert f"{journal}: is a file with 2 names (a hard link)" in err and err.count("\n") == 1
    assert victim.read_text() == SECRET


def test_the_journal_is_never_appended_through_a_link(tmp_path, victim):
    from optdesign.fronts.store import Journal
    journal = Journal(tmp_path / "points.jsonl")
    journal.start({"points": 3}, resume=False)
    (tmp_path / "points.jsonl").unlink()
    (tmp_path / "points.jsonl").symlink_to(victim)         # swapped in during the run
    with pytest.raises(ProblemError, match="link"):
        journal.append({"key": [4, 0], "delta": 0.1})
    assert victim.read_text() == SECRET


# --------------------------------------------------------------------------- init
def test_init_into_a_kernel_folder_names_out_not_a_temporary(capsys):
    assert main(["init", "--out", "/proc/x.yaml"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("optdesign: --out '/proc/x.yaml'") and ".tmp" not in err
