"""``optdesign explore`` in headless Chromium, driven by Playwright: a length slider and a
bound slider moved with the keyboard, δ and the drawing checked against the exact
evaluator, "follow" against a cold solve of the moved bound, save against ``analyze
--design``, a design that does not assemble, a front's point loaded, and no request that
leaves 127.0.0.1."""
import json
import os
import signal
import subprocess
import sys
import time

import pytest

from tests.conftest import FLAGS, ROOT, file_data, run_main

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"
#: a page's figures are exact: δ as shown (6 decimals) equals the evaluator's rounded
TIMEOUT_MS = 30_000


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """``optdesign explore problems/sharkov2022_disc.yaml --no-browser --front DIR`` in a
    process of its own (a front of two points of the disc problem beside it): (its URL, the
    process, the front's CSV)."""
    from optdesign import solve
    from optdesign.explorer.command import free_port

    folder = tmp_path_factory.mktemp("explore")
    front = folder / "front"
    front.mkdir()
    rows = []
    for floor in (125, 135):
        best = solve(file_data(DISC, constraints={"min_transmission_angle_deg": 40,
                                                  "min_pin_radius": floor}))
        rows.append(best.design | {"delta": best.delta, "ratio": best.ratio,
                                   "status": "optimal"})
    keys = list(rows[0])
    (front / "pareto.csv").write_text(",".join(keys) + "\n" + "".join(
        ",".join(str(r[k]) for k in keys) + "\n" for r in rows))
    port = free_port(None)
    env = os.environ | {"OPTDESIGN_SERVER": "off", "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "optdesign", "explore", str(DISC),
                             "--no-browser", "--port", str(port), "--front", str(front)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, cwd=folder)
    line = proc.stdout.readline()
    assert f"served at http://127.0.0.1:{port}/" in line, (line, proc.stderr.read())
    yield f"http://127.0.0.1:{port}/", proc, rows
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)


@pytest.fixture(scope="module")
def browser(chromium):
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=chromium, headless=True,
                              args=[f for f in FLAGS if f != "--headless"])
        yield b
        b.close()


def _text(page, css: str) -> str:
    return page.locator(css).first.inner_text()


def _value(page, name: str) -> float:
    return float(page.locator(f".explore-length-{name} input").first.input_value())


def _wait_text(page, css: str, needle: str) -> str:
    deadline = time.monotonic() + TIMEOUT_MS / 1000
    while time.monotonic() < deadline:
        if page.locator(css).count() and needle in _text(page, css):
            return _text(page, css)
        time.sleep(0.05)
    raise AssertionError(f"{needle!r} never appeared in {css} "
                         f"({_text(page, css) if page.locator(css).count() else 'absent'})")


def _links(page) -> dict:
    return page.evaluate("() => { const d = Bokeh.documents[0].get_model_by_name("
                         "'explore-links').data; return {x0: Array.from(d.x0), "
                         "y0: Array.from(d.y0), x1: Array.from(d.x1), y1: Array.from(d.y1)}; }")


def _expected_delta(values: dict, problem=DISC) -> str:
    from optdesign import analyze

    return analyze(problem, values).ripples().worst.text(6)


def test_the_page_follows_the_exact_evaluator_and_the_solver(served, browser, tmp_path):
    url, proc, front = served
    page = browser.new_page(viewport={"width": 1400, "height": 1300})
    hosts = []
    page.on("request", lambda r: hosts.append(r.url.split("/")[2]))
    page.goto(url)
    page.wait_for_selector(".explore-delta", timeout=TIMEOUT_MS)
    start = {"l0": 225.0, "l1": 20.0, "l2": 225.0, "l2_prime": 100.0, "l3": 56.0,
             "phases": 6}
    assert _text(page, ".explore-delta") == _expected_delta(start)
    before = _links(page)

    # a length slider: l3 up by five steps of its handle (0.2 mm each)
    page.locator(".explore-length-l3 .noUi-handle").first.focus()
    for _ in range(5):
        page.keyboard.press("ArrowRight")
    deadline = time.monotonic() + 30
    while _value(page, "l3") != pytest.approx(57.0) and time.monotonic() < deadline:
        time.sleep(0.05)
    moved = start | {"l3": _value(page, "l3")}
    assert moved["l3"] == pytest.approx(57.0, abs=1e-9)
    # the number field shows the step's decimals, whatever float noise the browser's
    # arithmetic left in the value (57.00000000000001 overflowed the field)
    assert page.locator(".explore-length-l3 input").first.input_value() == "57.0"
    expected = _expected_delta(moved)
    assert _wait_text(page, ".explore-delta", expected) == expected
    from optdesign import load_problem
    from optdesign.evaluation.design import Design
    from optdesign.figures.design import linkage
    from optdesign.explorer.page import Page  # noqa: F401  (the page's module imports)

    joints = linkage(Design.from_problem(load_problem(DISC), moved)).at(0.0)
    after = _links(page)
    assert after != before
    ends = {(round(x, 6), round(y, 6)) for x, y in zip(after["x1"], after["y1"])}
    assert (round(joints["B1"][0], 6), round(joints["B1"][1], 6)) in ends

    # re-optimise, then follow a bound slider: the pin radius up by ten steps (0.5 mm)
    page.locator(".explore-reoptimise button").first.click()
    _wait_text(page, ".explore-message-text", "re-optimised: optimal")
    page.locator(".explore-follow input").first.check()
    page.locator(".explore-bound-constraints-min_pin_radius .noUi-handle").first.focus()
    for _ in range(10):
        page.keyboard.press("ArrowRight")
    deadline = time.monotonic() + 60
    from optdesign import solve

    cold = solve(file_data(DISC, constraints={"min_transmission_angle_deg": 40,
                                              "min_pin_radius": 130}))
    while time.monotonic() < deadline:
        bound = page.locator(".explore-bound-constraints-min_pin_radius input").first
        if float(bound.input_value()) == 130 and \
                abs(_value(page, "l2") - _value(page, "l2_prime") - 130) < 1e-3:
            break
        time.sleep(0.1)
    _wait_text(page, ".explore-message-text", "re-optimised: optimal")
    for k in ("l0", "l2", "l2_prime", "l3"):
        assert _value(page, k) == pytest.approx(cold.design[k], abs=1e-4), k
    assert _text(page, ".explore-delta") == f"{cold.ripples().worst.label} = " \
                                            f"{cold.delta:.6f}"
    assert "pin_radius" in _text(page, ".explore-binding-text")

    # save: a design.yaml analyze --design reads back to the same δ
    saved = tmp_path / "saved_design.yaml"
    page.locator(".explore-save-as input").first.fill(str(saved))
    page.locator(".explore-save-as input").first.press("Enter")
    page.locator(".explore-save button").first.click()
    _wait_text(page, ".explore-message-text", f"saved {saved}")
    code, out = run_main(["analyze", DISC, "--design", saved, "--json"])
    named = json.loads(out)["delta_named"]["worst"]
    assert code == 0 and f"{named['label']} = {named['delta']:.6f}" == \
        _text(page, ".explore-delta")

    # a slider pushed to a design that does not assemble: one line, and the page goes on
    page.locator(".explore-length-l3 .noUi-handle").first.focus()
    page.keyboard.press("Home")
    _wait_text(page, ".explore-message-text", "does not assemble at crank angle")
    _wait_text(page, ".explore-headline-text", "does not assemble")
    page.keyboard.press("End")
    _wait_text(page, ".explore-delta", "δ (midrange, worst over e = 1)")

    # a front's point, picked on its plot, loads its design
    page.evaluate("() => { const s = Bokeh.documents[0].get_model_by_name('explore-front');"
                  " s.selected.indices = [1]; }")
    _wait_text(page, ".explore-message-text", "loaded point 2 of the front")
    assert _value(page, "l2_prime") == pytest.approx(front[1]["l2_prime"], abs=1e-4)
    assert _text(page, ".explore-delta").endswith(f"{front[1]['delta']:.6f}")

    page.screenshot(path=str(tmp_path / "explore.png"), full_page=True)
    assert set(hosts) == {url.split("/")[2]}           # nothing from a CDN
    assert proc.poll() is None                          # still serving
    page.close()


def test_ctrl_c_ends_the_server_cleanly(served):
    _, proc, _ = served
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=30) == 0
    err = proc.stderr.read()
    assert err.strip().splitlines()[-1] == "optdesign explore: stopped"
    assert "Traceback" not in err
