"""`twmr run --live` in a real browser: headless Chromium (Debian's chromium and chromium-driver)
driven by selenium opens the page while a paced paper run goes, sees the traces grow and the XY
view hold the path and its reference, and what it drew equals the stored result."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is in the [test] extra")
pytestmark = pytest.mark.skipif(
    CHROMIUM is None or DRIVER is None,
    reason="headless Chromium is not installed (Debian's chromium and chromium-driver; "
           ".ci/run installs them)")


@pytest.fixture
def browser():
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                "--window-size=1400,900"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(DRIVER), options=options)
    driver.set_script_timeout(30)
    yield driver
    driver.quit()


def _start_run(out: Path, stop: float = 8.0, pace: str = "true", scenario: Path = SCENARIO
               ) -> tuple[subprocess.Popen[str], str, list[str]]:
    """A paced paper run with a live view on a free port; the process, the page's URL and the
    lines of stderr so far (filled on by a thread)."""
    env = {**os.environ, "TWMR_CACHE_DIR": os.environ.get("TWMR_CACHE_DIR",
                                                          str(out.parent / "cache"))}
    proc = subprocess.Popen(
        [sys.executable, "-m", "twmr.cli", "run", str(scenario), "--set",
         f"experiment.realtime={pace}", "--set", f"experiment.stop={stop}", "--live",
         "127.0.0.1:0", "--live-keep", "--format", "none", "--out", str(out)],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, env=env, cwd=out.parent)
    lines: list[str] = []
    found = threading.Event()

    def read() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.append(line)
            if line.startswith("live view: "):
                found.set()

    threading.Thread(target=read, daemon=True).start()
    if not found.wait(120):
        proc.kill()
        pytest.fail(f"no 'live view:' line from twmr run: {''.join(lines)}")
    url = next(ln for ln in lines if ln.startswith("live view: ")).split(": ", 1)[1].strip()
    return proc, url, lines


def _points(driver) -> int:
    return driver.execute_script(
        "const c = window.twmrLive && twmrLive.charts[0]; return c ? c.data[0].length : 0;")


def test_live_page_streams_a_paced_run(browser, tmp_path):
    from selenium.webdriver.support.ui import WebDriverWait

    out = tmp_path / "run"
    proc, url, lines = _start_run(out)
    try:
        assert url.startswith("http://127.0.0.1:")
        browser.get(url)
        wait = WebDriverWait(browser, 60, poll_frequency=0.2)
        wait.until(lambda d: _points(d) > 0)
        first = _points(browser)
        ended_early = browser.execute_script("return twmrLive.end !== null;")
        assert not ended_early, "the run ended before the page read its first points"
        wait.until(lambda d: _points(d) > first)
        assert _points(browser) > first

        xy = browser.execute_script(
            "return twmrLive.xy.series.slice(1).map((s, i) => "
            "[s.label, twmrLive.xy.data[i + 1][0].length]);")
        assert sorted(label for label, _ in xy) == ["plant.pose", "ref.position"]
        assert all(n > 1 for _, n in xy)
        legends = browser.execute_script(
            "return twmrLive.charts.flatMap(c => c.series.map(s => s.label));")
        assert {"plant.pose x_M", "plant.pose y_M", "plant.pose theta"} <= set(legends)
        browser.save_screenshot(str(tmp_path / "live.png"))
        assert (tmp_path / "live.png").stat().st_size > 10_000

        from websockets.sync.client import connect

        with connect(url.replace("http://", "ws://") + "ws") as second:
            start = json.loads(second.recv(timeout=30))
            assert start["type"] == "start"
            assert start["columns"] == browser.execute_script("return twmrLive.columns;")

        WebDriverWait(browser, 120, poll_frequency=0.5).until(
            lambda d: d.execute_script("return twmrLive.end && twmrLive.end.status;"))
        end = browser.execute_script("return twmrLive.end;")
        assert end["status"] == "completed", end
        status = browser.execute_script("return document.getElementById('status').textContent;")
        assert "paper_trajectory1" in status and "completed" in status, status
        browser.save_screenshot(str(tmp_path / "live_end.png"))
        columns = browser.execute_script("return twmrLive.columns;")
        page = np.array(browser.execute_script("return twmrLive.data;"), dtype=float).T
        dropped = browser.execute_script("return twmrLive.dropped;")
    finally:
        proc.send_signal(signal.SIGINT)
        rc = proc.wait(60)
    assert rc == 0, "".join(lines)

    import pyarrow.ipc

    with pyarrow.ipc.open_stream(out / "result.arrows") as reader:
        table = reader.read_all()
    stored = np.column_stack([table[c].to_numpy() for c in columns])
    at = np.searchsorted(stored[:, 0], page[:, 0])
    assert np.array_equal(stored[at], page)  # every drawn row is a recorded row, bit for bit
    # a page that reads gets every row: rows not yet sent gather into its next frame
    assert dropped == 0 and len(page) == len(stored), (dropped, len(page), len(stored))


def test_the_xy_view_holds_the_path_with_more_points_than_pixels(browser, tmp_path):
    """The paper run to 30 s is 3001 rows at the scenario's decimation, all of them on the page:
    more than four points per pixel of the XY view's width, where uPlot draws a min and a max
    per pixel column as if x were sorted, and the path collapsed into two vertical lines (first
    seen at 13.6 s). The path on the canvas spans the plot's width."""
    from selenium.webdriver.support.ui import WebDriverWait

    proc, url, _ = _start_run(tmp_path / "run", stop=30.0, pace="4")
    try:
        browser.get(url)
        WebDriverWait(browser, 120, poll_frequency=0.5).until(
            lambda d: d.execute_script("return twmrLive.end && twmrLive.end.status;"))
        rows = browser.execute_script("return twmrLive.data[0].length;")
        assert rows == 3001  # every row, however busy the machine
        assert rows > 4 * browser.execute_script("return twmrLive.xy.bbox.width;")
        spans = []
        for at in (13.5, None):  # the page as it was at t = 13.5 s (the default 10 s window),
            if at is not None:   # where the path first collapsed, then at the end
                browser.execute_script(f"""
                    twmrLive.kept = twmrLive.data;
                    const n = twmrLive.data[0].findIndex(t => t > {at});
                    twmrLive.data = twmrLive.data.map(a => a.slice(0, n));
                    draw(); twmrLive.xy.redraw();""")
            else:
                browser.execute_script("twmrLive.data = twmrLive.kept; draw(); "
                                       "twmrLive.xy.redraw();")
            assert browser.execute_script("return twmrLive.window;") == 10
            spans.append(browser.execute_script("""
            const u = twmrLive.xy, c = u.ctx.canvas, b = u.bbox;
            const img = u.ctx.getImageData(b.left, b.top, b.width, b.height).data;
            // the two series' colours, COLOURS[0] and [1]: the path covers its reference
            // where it tracks it
            const wants = [[0x00, 0x72, 0xB2], [0xD5, 0x5E, 0x00]];
            const hit = new Set();
            for (let i = 0; i < img.length; i += 4) {
              for (const want of wants)
                if (Math.abs(img[i] - want[0]) + Math.abs(img[i + 1] - want[1]) +
                    Math.abs(img[i + 2] - want[2]) < 40 && img[i + 3] > 200)
                  hit.add((i / 4) % b.width);
            }
            return [hit.size, b.width];"""))
        browser.save_screenshot(str(tmp_path / "xy.png"))
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    for hit, width in spans:
        assert hit > 0.1 * width, spans  # the paths run across (collapsed: 2 columns)


def test_the_xy_view_draws_the_robot_at_its_last_pose(browser, tmp_path):
    """The plant describes its vehicle (`bodies()`): the page draws it from above at the last
    recorded pose, its platform where the pose and the heading put it."""
    from selenium.webdriver.support.ui import WebDriverWait

    proc, url, _ = _start_run(tmp_path / "run", stop=3.0, pace="4")
    try:
        browser.get(url)
        WebDriverWait(browser, 120, poll_frequency=0.5).until(
            lambda d: d.execute_script("return twmrLive.end && twmrLive.end.status;"))
        browser.execute_script("twmrLive.xy.redraw();")
        vehicle, pixel = browser.execute_script("""
            const v = twmrLive.vehicles[0], u = twmrLive.xy;
            const [cx, cy] = v.platform;  // a point of the platform beside the heading line
            return [v, Array.from(u.ctx.getImageData(Math.round(cx), Math.round(cy), 1, 1).data)];
            """)
        data = browser.execute_script("return twmrLive.data;")
        columns = browser.execute_script("return twmrLive.columns;")
        browser.save_screenshot(str(tmp_path / "robot.png"))
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    last = {c: data[j][-1] for j, c in enumerate(columns)}
    assert vehicle["port"] == "plant.pose"
    assert vehicle["x"] == last["plant.pose[1]"] and vehicle["y"] == last["plant.pose[2]"]
    assert vehicle["heading"] == last["plant.pose[3]"]
    assert pixel[:3] == [140, 140, 153]  # the platform's grey where the pose puts it


def _severe(driver) -> list[str]:
    return [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def test_the_3d_view_draws_the_robot_at_its_recorded_pose(browser, tmp_path):
    """The 3D view puts the plant's vehicle at the last recorded pose: the platform's top face,
    projected from the pose and heading, is where the canvas is painted its grey; the reference
    path is drawn; the page logs no error."""
    from selenium.webdriver.support.ui import WebDriverWait

    proc, url, _ = _start_run(tmp_path / "run", stop=3.0, pace="4")
    try:
        browser.get(url)
        WebDriverWait(browser, 120, poll_frequency=0.5).until(
            lambda d: d.execute_script("return twmrLive.end && twmrLive.end.status;"))
        vehicle, pixel, blue = browser.execute_script("""
            document.getElementById("vectors").click();  // arrows off: the platform's top seen
            const v = twmrLive.view.drawn[0], ctx = twmrLive.view.canvas.getContext("2d");
            const [cx, cy] = v.platform;
            const img = ctx.getImageData(0, 0, twmrLive.view.canvas.width,
                                         twmrLive.view.canvas.height).data;
            let blue = 0;   // pixels of the first path's colour, COLOURS[0]
            for (let i = 0; i < img.length; i += 4)
              if (Math.abs(img[i]) + Math.abs(img[i + 1] - 0x72) + Math.abs(img[i + 2] - 0xB2) < 40)
                blue += 1;
            return [v, Array.from(ctx.getImageData(Math.round(cx), Math.round(cy), 1, 1).data),
                    blue];""")
        arrows, magenta = browser.execute_script("""
            document.getElementById("vectors").click();   // the arrows on again
            const v = twmrLive.view.drawn[0], ctx = twmrLive.view.canvas.getContext("2d");
            const img = ctx.getImageData(0, 0, twmrLive.view.canvas.width,
                                         twmrLive.view.canvas.height).data;
            let magenta = 0;   // the slip arrows' colour, #CC00CC
            for (let i = 0; i < img.length; i += 4)
              if (Math.abs(img[i] - 0xCC) + img[i + 1] + Math.abs(img[i + 2] - 0xCC) < 40)
                magenta += 1;
            return [v.arrows, magenta];""")
        data = browser.execute_script("return twmrLive.data;")
        columns = browser.execute_script("return twmrLive.columns;")
        errors = _severe(browser)
        browser.save_screenshot(str(tmp_path / "view3d.png"))
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    last = {c: data[j][-1] for j, c in enumerate(columns)}
    assert vehicle["port"] == "plant.pose"
    assert (vehicle["x"], vehicle["y"], vehicle["heading"]) == (
        last["plant.pose[1]"], last["plant.pose[2]"], last["plant.pose[3]"])
    assert pixel[:3] == [140, 140, 153]  # the platform's top where the pose puts it
    assert blue > 50, blue               # the reference path on the ground
    # the plant's vectors (slip velocities, disturbance torques) at their recorded values, each
    # arrow's tip where its value, the pose and the plant's geometry put it
    assert [a["label"] for a in arrows] == ["slip mu_R'", "slip mu_L'", "slip delta'",
                                            "tau_d R", "tau_d L"]
    x, y, th = vehicle["x"], vehicle["y"], vehicle["heading"]
    for a, column, at, along, scale in zip(arrows, (
            "plant.slip_rate[1]", "plant.slip_rate[2]", "plant.slip_rate[3]",
            "plant.disturbance[1]", "plant.disturbance[2]"),
            ((0, -0.75), (0, 0.75), (0, 0), (0, -0.75), (0, 0.75)),
            ((1, 0), (1, 0), (0, 1), (1, 0), (1, 0)), (0.25, 0.25, 0.25, 0.2, 0.2), strict=True):
        assert a["value"] == last[column]
        bx, by = at[0] + along[0] * scale * a["value"], at[1] + along[1] * scale * a["value"]
        assert a["tip"][:2] == pytest.approx([x + np.cos(th) * bx - np.sin(th) * by,
                                              y + np.sin(th) * bx + np.cos(th) * by], abs=1e-12)
    assert magenta > 20, magenta         # slip arrows drawn
    assert errors == [], errors


def test_the_diagram_shows_every_block_and_a_port_click_opens_its_scope(browser, tmp_path):
    """The page shows the scenario's diagram: a block for each of the scenario file's components,
    a wire for each of its connections; a click on ctrl.s (not recorded) says so, on ctrl.d_hat
    (recorded, not shown at first) opens its scope."""
    import yaml
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    scenario = yaml.safe_load(SCENARIO.read_text(encoding="utf-8"))
    proc, url, _ = _start_run(tmp_path / "run", stop=2.0, pace="4")
    try:
        browser.get(url)
        WebDriverWait(browser, 120, poll_frequency=0.5).until(
            lambda d: d.execute_script(
                "return document.querySelectorAll('#diagram g.block').length > 0;"))
        blocks = browser.execute_script(
            "return [...document.querySelectorAll('#diagram g.block')].map(g => g.dataset.name);")
        wires = browser.execute_script(
            "return [...document.querySelectorAll('#diagram path.wire')].map("
            "p => p.dataset.src + ' -> ' + p.dataset.dst);")
        before = browser.execute_script("return [...twmrLive.selected];")
        browser.find_element(By.CSS_SELECTOR, '#diagram g.port[data-port="ctrl.s"]').click()
        unrecorded = browser.find_element(By.ID, "diagramnote").text
        browser.find_element(By.CSS_SELECTOR,
                             '#diagram g.port.output[data-port="ctrl.d_hat"]').click()
        after = browser.execute_script("return [...twmrLive.selected];")
        charted = browser.execute_script(
            "return twmrLive.charts.flatMap(c => c.cols.map(i => twmrLive.columns[i]));")
        shown = browser.execute_script(
            "return [...document.querySelectorAll('#diagram g.port.shown')].map("
            "g => g.dataset.port);")
        errors = _severe(browser)
        browser.save_screenshot(str(tmp_path / "diagram.png"))
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    assert sorted(blocks) == sorted(scenario["components"])
    assert sorted(wires) == sorted(scenario["connections"])
    assert "ctrl.s is not recorded" in unrecorded
    assert "ctrl.d_hat[1]" not in before
    assert {"ctrl.d_hat[1]", "ctrl.d_hat[2]"} <= set(after) & set(charted)
    assert "ctrl.d_hat" in shown
    assert errors == [], errors


def test_a_subsystem_closes_into_one_block_and_opens_again(browser, tmp_path):
    """The nested paper scenario: a click on the robot's frame draws it as one block whose
    ports are the inner ports its wires cross, the wires inside hidden; a click on its pose
    port opens that scope; a click on the block opens the subsystem again."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    def names() -> list[str]:
        return browser.execute_script(
            "return [...document.querySelectorAll('#diagram g.block')].map(g => g.dataset.name);")

    nested = ROOT / "scenarios" / "nested" / "paper_trajectory1_asmc.yaml"
    inside = ["ctrl", "ref", "robot.motor", "robot.plant", "robot.slip"]
    proc, url, _ = _start_run(tmp_path / "run", stop=2.0, pace="4", scenario=nested)
    try:
        browser.get(url)
        wait = WebDriverWait(browser, 120, poll_frequency=0.2)
        wait.until(lambda d: sorted(names()) == inside)
        opened = names()
        browser.find_element(By.CSS_SELECTOR,
                             '#diagram g.subsystem[data-name="robot"] text').click()
        wait.until(lambda d: sorted(names()) == ["ctrl", "ref", "robot"])
        closed = names()
        ports = browser.execute_script(
            "return [...document.querySelectorAll('#diagram g.block.closed g.port')].map("
            "g => g.dataset.port);")
        wires = browser.execute_script(
            "return [...document.querySelectorAll('#diagram path.wire')].map("
            "p => p.dataset.src + ' -> ' + p.dataset.dst);")
        browser.find_element(
            By.CSS_SELECTOR, '#diagram g.port[data-port="robot.plant.pose"]').click()
        charted = browser.execute_script(
            "return twmrLive.charts.flatMap(c => c.cols.map(i => twmrLive.columns[i]));")
        browser.find_element(By.CSS_SELECTOR, '#diagram g.block.closed text.head').click()
        wait.until(lambda d: sorted(names()) == inside)
        reopened = names()
        errors = _severe(browser)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    assert sorted(opened) == inside
    assert sorted(closed) == ["ctrl", "ref", "robot"]
    assert sorted(ports) == ["robot.motor.torque_command", "robot.plant.pose",
                             "robot.plant.wheel_speed"]
    # only the wires that cross the subsystem's edge, and the ones outside it
    assert all(not (w.split(" -> ")[0].startswith("robot.")
                    and w.split(" -> ")[1].startswith("robot.")) for w in wires)
    assert "ctrl.torque -> robot.motor.torque_command" in wires
    assert "robot.plant.pose[1]" in charted
    assert sorted(reopened) == sorted(opened)
    assert errors == [], errors


def test_the_page_pauses_steps_and_resumes_the_run(browser, tmp_path):
    """Pause holds the run (no row arrives however long the page waits for one), Step 0.1 s
    takes exactly 100 steps (10 rows at decimation 10) and pauses again, Resume runs it to the
    end; summary.json says it completed after a pause."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select, WebDriverWait

    def rows() -> int:
        return browser.execute_script("return twmrLive.data.length ? twmrLive.data[0].length "
                                      ": 0;")

    def last_time() -> float:
        return browser.execute_script("return twmrLive.data[0][twmrLive.data[0].length - 1];")

    proc, url, _ = _start_run(tmp_path / "run", stop=6.0, pace="2")
    try:
        browser.get(url)
        wait = WebDriverWait(browser, 120, poll_frequency=0.2)
        wait.until(lambda d: rows() > 20)
        browser.find_element(By.ID, "runpause").click()
        wait.until(lambda d: d.execute_script("return twmrLive.runPaused === true;"))
        # the rows taken before the pause arrive; then none: the run waits
        settled = []
        wait.until(lambda d: settled.append(rows()) or (len(settled) > 5
                                                        and len(set(settled[-5:])) == 1))
        held, t_held = rows(), last_time()
        threading.Event().wait(1.0)
        assert rows() == held  # a second later: still nothing (the run is paused)
        Select(browser.find_element(By.ID, "stepsize")).select_by_value("0.1")
        browser.find_element(By.ID, "runstep").click()
        wait.until(lambda d: rows() >= held + 10)
        threading.Event().wait(1.0)
        stepped, t_stepped = rows(), last_time()
        browser.find_element(By.ID, "runpause").click()  # Resume
        wait.until(lambda d: d.execute_script("return twmrLive.end && twmrLive.end.status;"))
        end = browser.execute_script("return twmrLive.end;")
        errors = _severe(browser)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    assert stepped == held + 10 and t_stepped == pytest.approx(t_held + 0.1, abs=1e-9)
    assert end["status"] == "completed" and end["steps_done"] == 6000
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["pacing"]["paused_s"] > 1.0
    assert errors == [], errors


def test_events_are_marked_on_the_scopes(browser, tmp_path):
    """A timed set event (its mark from the start) and a condition event (its mark when it
    fires, pushed to the page) are drawn as dashed vertical lines on each scope at their times,
    labelled; the fired one at the time summary.json gives."""
    from selenium.webdriver.support.ui import WebDriverWait

    scenario = tmp_path / "events.yaml"
    scenario.write_text(SCENARIO.read_text(encoding="utf-8") + (
        "events:\n  - {at: 0.5, set: ctrl.k, value: 50.0}\n"
        "  - {when: 'plant.pose[1] < 0.3', set: ctrl.k, value: 55.0}\n"), encoding="utf-8")
    proc, url, _ = _start_run(tmp_path / "run", stop=2.0, pace="2", scenario=scenario)
    try:
        browser.get(url)
        WebDriverWait(browser, 120, poll_frequency=0.5).until(
            lambda d: d.execute_script("return twmrLive.end && twmrLive.end.status;"))
        browser.execute_script("twmrLive.window = 'all'; draw();")
        marks = browser.execute_script("return twmrLive.marks;")
        grey = browser.execute_script("""
            const u = twmrLive.charts[0], out = [];
            u.redraw();
            for (const m of twmrLive.marks) {
              const x = Math.round(u.valToPos(m.at, "x", true));
              const col = u.ctx.getImageData(x, u.bbox.top, 1, u.bbox.height).data;
              let n = 0;
              for (let i = 0; i < col.length; i += 4)
                if (Math.abs(col[i] - 120) < 25 && Math.abs(col[i + 1] - 120) < 25 &&
                    Math.abs(col[i + 2] - 120) < 25) n += 1;
              out.push(n);
            }
            return out;""")
        errors = _severe(browser)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    fired = summary["fired"][0]
    assert sorted(m["at"] for m in marks) == sorted([0.5, fired["at"]])
    assert any(m["text"] == "ctrl.k set (plant.pose[1] < 0.3)" for m in marks)
    assert all(n > 20 for n in grey), grey  # a dashed line down each mark's pixel column
    assert errors == [], errors
