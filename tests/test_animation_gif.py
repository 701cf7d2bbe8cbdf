"""The GIF of ``optdesign animate`` is rendered by two processes at once and is still, byte for
byte, the file matplotlib's PillowWriter writes of the same figure in one."""
import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def turn():
    from optdesign.evaluation.design import Design
    from optdesign.export.animation import turn as turn_of
    from optdesign.problem.loader import load_problem

    problem = load_problem(ROOT / "problems" / "sharkov2022.yaml")
    return turn_of(Design.from_problem(problem), problem.stroke, problem.input_speed, 1.0, 13)


def _one_process(fig, draw_frame, count, path, fps):
    """What ``movie`` did before the frames were split: PillowWriter, every frame here."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    FuncAnimation(fig, draw_frame, frames=count, blit=False).save(
        str(path), writer=PillowWriter(fps=fps))


def test_the_gif_drawn_in_two_processes_is_the_one_drawn_in_one(turn, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    from optdesign.export import animation

    drawn_by = tmp_path / "pids"
    halves = animation._palette_frames

    def recorded(*args):
        with open(drawn_by, "a") as fh:
            fh.write(f"{os.getpid()}\n")
        return halves(*args)

    with monkeypatch.context() as m:
        m.setattr(animation, "_palette_frames", recorded)
        animation.movie(turn, "a turn of thirteen frames", tmp_path / "two.gif", fps=8)
    assert len(set(drawn_by.read_text().split())) == 2            # two processes drew
    with monkeypatch.context() as m:
        m.setattr(animation, "_gif", _one_process)
        animation.movie(turn, "a turn of thirteen frames", tmp_path / "one.gif", fps=8)
    two, one = (tmp_path / "two.gif").read_bytes(), (tmp_path / "one.gif").read_bytes()
    assert len(one) > 10_000 and two == one


def test_where_no_child_can_be_forked_the_gif_is_drawn_here_the_same(turn, tmp_path,
                                                                     monkeypatch):
    import matplotlib
    import multiprocessing

    matplotlib.use("Agg")
    from optdesign.export import animation

    animation.movie(turn, "t", tmp_path / "forked.gif", fps=8)

    def no_fork(method=None):
        raise ValueError("cannot find context for 'fork'")

    monkeypatch.setattr(multiprocessing, "get_context", no_fork)
    animation.movie(turn, "t", tmp_path / "here.gif", fps=8)
    assert (tmp_path / "here.gif").read_bytes() == (tmp_path / "forked.gif").read_bytes()
