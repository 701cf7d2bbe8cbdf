"""How live the explorer is: a slider's round trip through the server and the page, and a
warm re-solve after a bound moves by 1 %, against a cold ``solve`` of the same file.

    python benchmarks/explorer_latency.py [--moves 30] [--rounds 3]

On the paper's six-phase problem (``problems/sharkov2022_disc.yaml``: n = 6, the paper's crank,
the other four lengths free; ``problems/sharkov2022.yaml`` fixes every length, so it has no
slider to move and nothing to solve) and on ``problems/free_design.yaml`` (counts 4-8):

* round trip: ``optdesign explore P --no-browser`` in a process of its own, headless Chromium
  driven by Playwright; a length slider's handle moved one step by the keyboard, and the time
  until the page has drawn the frame that shows the new δ (the browser's event, the server's
  exact evaluation and redraw, the page's update and its repaint of the plots), ``--moves``
  times, each a new design (no evaluation is repeated); the exact evaluation alone (in
  process, the same moves) beside it;
* re-solve: the file's optimum (a cold ``solve``), then every bound that binds there moved by
  1 % the tight way and one polish warm-started from the optimum on the NLP already built
  (:class:`optdesign.explorer.session.Session`), against a cold ``solve`` of the file with that
  bound (in process, ``solve_time_s``); each the median of ``--rounds``; "same δ" when both
  end at the same δ to 1e-7.

How the page is watched: before each move a script in the page finds the headline's pane
once (a walk through every shadow root), then reads its text at each animation frame; the
frame in which the text has changed is the one that paints the new δ, and the move ends when
that frame's work is done (a task queued from its animation callback runs after the frame's
style, layout and paint, and after the plots' repaint, which Bokeh does in the same frame's
callbacks). Earlier runs walked every shadow root at each frame (about a millisecond of the
page's own thread each time, taken from the page being measured) and ended a move in the
animation callback that first saw the new text, before that frame's repaint: the round trips
they measured are shorter by that repaint.

The machine's load average when the run ended is written beside the round trips: on a shared
machine the round trip is mostly waiting for a core. ``--table-only`` writes the tables
again from the JSON twin.

Targets: a round trip under 100 ms, a warm re-solve under a fifth of the cold
solve. Writes benchmarks/results/explorer_latency.md and .json.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
PROBLEMS = ("sharkov2022_disc.yaml", "free_design.yaml")
#: the slider moved on the page
SLIDER = "l3"
#: arms the page before a move: ``window.__shown`` resolves once the frame showing a new δ is
#: drawn (see the module's text); the headline's pane is found once, walking the shadow roots
ARM = """() => {
  const find = (root) => {
    const hit = root.querySelector('.explore-headline');
    if (hit) return hit;
    for (const e of root.querySelectorAll('*'))
      if (e.shadowRoot) { const t = find(e.shadowRoot); if (t !== null) return t; }
    return null;
  };
  if (!(window.__headline && window.__headline.isConnected)) window.__headline = find(document);
  const pane = window.__headline;
  const read = () => {
    const text = (pane.shadowRoot || pane).querySelector('.explore-headline-text');
    return text === null ? null : text.textContent;
  };
  const before = read();
  window.__shown = new Promise((resolve, reject) => {
    const give_up = setTimeout(() => reject(new Error('δ unchanged after 30 s')), 30000);
    const tick = () => {
      if (read() !== before) { clearTimeout(give_up); setTimeout(resolve, 0); }
      else requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  });
}"""


def round_trips(problem: Path, moves: int) -> dict:
    """Slider to δ on the page [ms] over ``moves`` moves (median, 90th percentile), and the
    exact evaluation alone in process [ms] (median)."""
    from playwright.sync_api import sync_playwright

    from optdesign.explorer.command import free_port
    from optdesign.explorer.session import Session

    port = free_port(None)
    env = os.environ | {"OPTDESIGN_SERVER": "off"}
    proc = subprocess.Popen([sys.executable, "-m", "optdesign", "explore", str(problem),
                             "--no-browser", "--port", str(port)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    try:
        if "served at" not in proc.stdout.readline():
            raise RuntimeError(proc.stderr.read())
        flags = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update"]
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path="/usr/bin/chromium", headless=True,
                                        args=flags)
            page = browser.new_page(viewport={"width": 1400, "height": 1300})
            page.goto(f"http://127.0.0.1:{port}/")
            page.wait_for_selector(".explore-delta", timeout=60_000)
            handle = page.locator(f".explore-length-{SLIDER} .noUi-handle").first
            handle.focus()
            times = []
            for i in range(moves + 2):
                page.evaluate(ARM)
                t0 = time.perf_counter()
                page.keyboard.press("ArrowRight")      # a new design every move
                page.evaluate("window.__shown")         # the frame showing the new δ drawn
                if i >= 2:                      # the first two warm the page up
                    times.append(1e3 * (time.perf_counter() - t0))
            browser.close()
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)
    session = Session.open(problem)
    alone = []
    for i in range(moves):
        session.set(SLIDER, session.values[SLIDER] + 0.2)
        t0 = time.perf_counter()
        session.evaluate()
        alone.append(1e3 * (time.perf_counter() - t0))
    times.sort()
    return {"median_ms": statistics.median(times),
            "p90_ms": times[min(len(times) - 1, int(0.9 * len(times)))],
            "evaluation_ms": statistics.median(alone), "moves": len(times)}


def resolves(problem: Path, rounds: int) -> list[dict]:
    """Per bound binding at the file's optimum: the warm re-solve after it moves by 1 % (the
    tight way) and the cold solve of the file so moved, medians of ``rounds``."""
    from optdesign import solve
    from optdesign.explorer.bounds import bounds_of, with_bound
    from optdesign.explorer.session import Session
    from optdesign.quantities.criteria import constraints_of
    from optdesign.problem.loader import load_problem, problem_from_dict

    base = load_problem(problem)
    cold = [solve(base) for _ in range(rounds)]
    optimum = cold[0].design
    binding = {a["name"].split("[")[0] for a in cold[0].active if a["kind"] == "constraint"}
    keys = {c.key(base): c.name for c in constraints_of(base)}
    data = yaml.safe_load(problem.read_text())
    out = []
    for b in bounds_of(base):
        if keys.get(b.key) not in binding or b.value == 0:
            continue
        value = b.value * (1.01 if b.side == "lower" else 0.99)
        session = Session.open(problem, optimum)
        session.prepare()
        warm, iterations, deltas = [], [], []
        for _ in range(rounds):
            session.load(optimum)
            session.set_bound(b.key, b.value)
            session.reoptimise()                # at the optimum: the NLP built, IPOPT warm
            session.set_bound(b.key, value)
            done = session.reoptimise()
            warm.append(done.time_s)
            iterations.append(done.iterations)
            deltas.append(done.delta)
        moved = problem_from_dict(with_bound(data, b.key, value), where=problem.name)
        colds = [solve(moved) for _ in range(rounds)]
        out.append({"problem": problem.name, "bound": b.key, "from": b.value, "to": value,
                    "warm_s": statistics.median(warm),
                    "iterations": int(statistics.median(iterations)),
                    "cold_s": statistics.median(r.solve_time_s for r in colds),
                    "file_cold_s": statistics.median(r.solve_time_s for r in cold),
                    "same_delta": abs(deltas[0] - colds[0].delta) < 1e-7,
                    "warm_delta": deltas[0], "cold_delta": colds[0].delta})
    return out


def tables(trips: dict, solves: list[dict], load: float) -> list[str]:
    lines = ["Each slider move: the exact evaluation through the server and the page "
             "(headless Chromium).", "",
             "| problem | slider → δ on the page, median [ms] | 90th percentile [ms] | "
             "exact evaluation alone [ms] | machine load (1-min average, 2 cores) |",
             "|---|---|---|---|---|"]
    for name, t in trips.items():
        lines.append(f"| {name} | {t['median_ms']:.0f} | {t['p90_ms']:.0f} | "
                     f"{t['evaluation_ms']:.0f} | {load:.1f} |")
    lines += ["", "A bound moved by 1 %: one polish warm-started from the optimum on the NLP "
              "already built, against a cold solve of the file so moved.", "",
              "| problem | bound moved 1 % | warm re-solve [s] | IPOPT iterations | "
              "cold solve [s] | warm / cold | same δ |", "|---|---|---|---|---|---|---|"]
    for r in solves:
        lines.append(f"| {r['problem']} | {r['bound'].split('.', 1)[1]}: {r['from']:g} → "
                     f"{r['to']:.4g} | {r['warm_s']:.3f} | {r['iterations']} | "
                     f"{r['cold_s']:.2f} | {r['warm_s'] / r['cold_s']:.2f} | "
                     f"{'yes' if r['same_delta'] else 'no'} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", type=int, default=30, help="slider moves per problem")
    ap.add_argument("--rounds", type=int, default=3, help="solves per median")
    ap.add_argument("--out", type=Path, default=RESULTS / "explorer_latency.md")
    ap.add_argument("--table-only", action="store_true",
                    help="write the tables again from the results' JSON twin, measure nothing")
    args = ap.parse_args(argv)
    if args.table_only:
        doc = json.loads(args.out.with_suffix(".json").read_text())
        lines = tables(doc["round_trips"], doc["resolves"], doc["meta"]["load_average"][0])
        args.out.write_text("\n".join(lines) + "\n")
        print("\n".join(lines))
        return 0
    trips, solves = {}, []
    for name in PROBLEMS:
        path = ROOT / "problems" / name
        trips[name] = round_trips(path, args.moves)
        print(name, trips[name], flush=True)
        solves += resolves(path, args.rounds)
        print(solves[-1], flush=True)
    meta = {"time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": platform.machine() + " " + platform.system(),
            "cores": os.cpu_count(), "moves": args.moves, "rounds": args.rounds,
            "load_average": os.getloadavg()}
    lines = tables(trips, solves, meta["load_average"][0])
    args.out.write_text("\n".join(lines) + "\n")
    args.out.with_suffix(".json").write_text(json.dumps(
        {"meta": meta, "round_trips": trips, "resolves": solves}, indent=2) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
