"""``make lab``: JupyterLab on the course folder, chapters and exercises side by side, no news prompt.

The lab really starts (``make -s lab`` with ``LAB_FLAGS``: free port, token, headless), answers
through its REST API, and is looked at in headless Chromium through the DevTools protocol;
it is stopped at the end and no process of it (server or kernel) may be left behind.

Set ``ROBOCOURSE_LAB_SCREENSHOT=/some/file.png`` to keep the screenshot the browser test takes.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from dataclasses import dataclass
from pathlib import Path

import psutil
import pytest

from robocourse.cli.lab import (
    OVERRIDES,
    check_overrides_against_schemas,
    default_workspace,
    workspaces_dir,
    write_default_workspace,
)

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
NOTIFICATION = "@jupyterlab/apputils-extension:notification"
NEWS_PROMPT = "official Jupyter news"
WIDTH, HEIGHT = 1400, 900


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@dataclass
class Lab:
    port: int
    token: str
    user_settings: Path

    def url(self, path: str) -> str:
        sep = "&" if "?" in path else "?"
        return f"http://127.0.0.1:{self.port}{path}{sep}token={self.token}"

    def get(self, path: str):
        return json.loads(urllib.request.urlopen(self.url(path), timeout=10).read())

    def send(self, method: str, path: str, body: dict | None = None):
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.url(path), data=data, method=method,
                                     headers={"Content-Type": "application/json"})
        raw = urllib.request.urlopen(req, timeout=30).read()
        return json.loads(raw) if raw else None


def _processes_using(marker: str, pgid: int | None = None) -> list[psutil.Process]:
    """Live processes whose command line names ``marker`` (or in process group ``pgid``)."""
    found = []
    for p in psutil.process_iter(["pid", "cmdline", "status"]):
        try:
            if p.info["status"] == psutil.STATUS_ZOMBIE:
                continue
            if os.getpgid(p.pid) == pgid or marker in " ".join(p.info["cmdline"] or []):
                found.append(p)
        except (ProcessLookupError, psutil.Error):
            continue
    return found


def _stop(proc: subprocess.Popen, marker: str, pgid: int | None = None, timeout: float = 30) -> list:
    """SIGTERM the process group of ``proc`` (SIGKILL if it lingers), then wait for every process
    naming ``marker`` to end; kill and return (pid, command line) of those that did not."""
    os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    deadline = time.monotonic() + timeout
    while (left := _processes_using(marker, pgid)) and time.monotonic() < deadline:
        time.sleep(0.2)
    stragglers = []
    for p in left:
        with contextlib.suppress(psutil.Error):
            stragglers.append((p.pid, p.cmdline()))
            p.kill()
    psutil.wait_procs(left, timeout=5)
    return stragglers


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    root = Path(__file__).resolve().parents[1]
    tmp = tmp_path_factory.mktemp("lab")
    port, token = _free_port(), "robocourse-test"
    # the layout a student saved in the venv must not decide what this test sees either: the
    # lab gets a fresh workspaces folder holding the course's default layout
    write_default_workspace(tmp / "workspaces", root)
    # and the browser test must never write the course's notebooks (JupyterLab autosaves every 2 min)
    docmanager = tmp / "user-settings/@jupyterlab/docmanager-extension/plugin.jupyterlab-settings"
    docmanager.parent.mkdir(parents=True)
    docmanager.write_text(json.dumps({"autosave": False}))
    flags = (f"--no-browser --port={port} --ServerApp.port_retries=0 --IdentityProvider.token={token} "
             f"--ServerApp.ip=127.0.0.1 --ServerApp.allow_root=True --LabApp.workspaces_dir={tmp / 'workspaces'}")
    # the student's own JupyterLab preferences (~/.jupyter) must not decide what this test sees
    env = dict(os.environ, JUPYTER_RUNTIME_DIR=str(tmp / "runtime"), JUPYTERLAB_SETTINGS_DIR=str(tmp / "user-settings"))
    proc = subprocess.Popen(["make", "-s", "lab", f"LAB_FLAGS={flags}"], cwd=root, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    server = Lab(port, token, tmp / "user-settings")
    try:
        deadline, ready = time.monotonic() + 120, False
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                server.get("/api/status")
                ready = True
                break
            except OSError:
                time.sleep(0.5)
        if not ready:
            os.killpg(proc.pid, signal.SIGKILL)
            pytest.fail(f"JupyterLab did not answer on port {port}: {proc.stdout.read1(5000)!r}")
        yield server
    finally:  # make and the server; the server shuts its kernels down (they use our runtime dir)
        left = _stop(proc, str(tmp / "runtime"), pgid=proc.pid)
        assert not left, f"processes of the lab outlived it: {left}"


def test_lab_serves_a_chapter_and_an_exercise_notebook(lab):
    root = lab.get("/api/contents/")
    dirs = {c["name"] for c in root["content"] if c["type"] == "directory"}
    assert {"chapters", "exercises"} <= dirs, dirs
    for path in ("chapters/00_setup_check.ipynb", "exercises/00_setup_exercises.ipynb"):
        nb = lab.get(f"/api/contents/{path}")
        assert nb["type"] == "notebook" and nb["format"] == "json"
        assert nb["content"]["metadata"]["kernelspec"]["name"] == "robocourse"
        assert len(nb["content"]["cells"]) > 3
    exercise = lab.get("/api/contents/exercises/00_setup_exercises.ipynb")["content"]
    code = "\n".join(c["source"] for c in exercise["cells"] if c["cell_type"] == "code")
    assert "raise NotImplementedError()" in code and "### BEGIN SOLUTION" not in code


def test_lab_default_kernel_is_the_course_kernel(lab):
    specs = lab.get("/api/kernelspecs")
    assert specs["default"] == "robocourse"
    assert specs["kernelspecs"]["robocourse"]["spec"]["display_name"] == "Python (robocourse)"
    kernel = lab.send("POST", "/api/kernels", {})  # no name: the server starts its default kernel
    try:
        assert kernel["name"] == "robocourse"
    finally:
        lab.send("DELETE", f"/api/kernels/{kernel['id']}")
    tracker = lab.get("/lab/api/settings/@jupyterlab/notebook-extension:tracker")
    assert tracker["schema"]["properties"]["autoStartDefaultKernel"]["default"] is True


def test_lab_kernels_talk_over_ipc_so_they_print_no_tcp_warning(lab):
    # issue 25: every kernel start logged "Kernel is running over TCP without encryption"; the lab's
    # kernels use IPC sockets in the runtime folder (this test's own: JUPYTER_RUNTIME_DIR)
    kernel = lab.send("POST", "/api/kernels", {})
    try:
        runtime = lab.user_settings.parent / "runtime"
        info = json.loads((runtime / f"kernel-{kernel['id']}.json").read_text())
        assert info["transport"] == "ipc" and info["ip"].startswith(str(runtime))
    finally:
        lab.send("DELETE", f"/api/kernels/{kernel['id']}")


def test_lab_news_and_update_check_are_off_by_default(lab):
    served = lab.get(f"/lab/api/settings/{NOTIFICATION}")
    props = served["schema"]["properties"]
    assert props["fetchNews"]["default"] == "false"  # "Never"; JupyterLab's own default is "none" (ask)
    assert props["checkForUpdates"]["default"] is False
    assert json.loads(served["raw"] or "{}") == {}  # defaults from the venv's overrides, nothing of the user's


def test_lab_default_workspace_opens_chapter_0_beside_its_exercise(lab):
    space = lab.get("/lab/api/workspaces/default")["data"]
    dock = space["layout-restorer:data"]["main"]["dock"]
    opened = [w for area in dock.get("children", [dock]) for w in area["widgets"]]
    assert opened == ["notebook:chapters/00_setup_check.ipynb", "notebook:exercises/00_setup_exercises.ipynb"]
    assert space["file-browser-filebrowser:cwd"]["path"] == ""
    assert space == default_workspace(Path(__file__).resolve().parents[1])["data"]


def test_make_lab_wrote_the_default_layout_into_the_venv_once(lab, root, tmp_path):
    from jupyterlab_server.workspaces_handler import WorkspacesManager

    venv = WorkspacesManager(str(workspaces_dir(root / ".venv"))).load("default")["data"]
    assert "layout-restorer:data" in venv  # the course's, or the student's own once rearranged
    mine = {"data": {"file-browser-filebrowser:cwd": {"path": "chapters"}}, "metadata": {"id": "/default"}}
    WorkspacesManager(str(tmp_path)).save("default", json.dumps(mine))
    assert write_default_workspace(tmp_path, root) is None  # a saved layout is kept
    assert WorkspacesManager(str(tmp_path)).load("default")["data"] == mine["data"]
    assert write_default_workspace(tmp_path, root, reset=True) is not None
    assert WorkspacesManager(str(tmp_path)).load("default")["data"] == default_workspace(root)["data"]


def test_overrides_are_checked_against_the_installed_jupyterlab_schemas(root):
    venv = root / ".venv"
    check_overrides_against_schemas(venv, OVERRIDES)  # what make lab writes is valid for this JupyterLab
    with pytest.raises(KeyError, match="has no setting 'fetchNewz'.*'fetchNews'"):
        check_overrides_against_schemas(venv, {NOTIFICATION: {"fetchNewz": "false"}})
    with pytest.raises(KeyError, match="plugin '@jupyterlab/apputils-extension:news' not found"):
        check_overrides_against_schemas(venv, {"@jupyterlab/apputils-extension:news": {"fetchNews": "false"}})
    with pytest.raises(ValueError, match=r"fetchNews=False is not a value.*\['true', 'false', 'none'\]"):
        check_overrides_against_schemas(venv, {NOTIFICATION: {"fetchNews": False}})
    with pytest.raises(FileNotFoundError, match="run `make setup` first"):
        check_overrides_against_schemas(root / "no-such-venv", OVERRIDES)


class Page:
    """One Chromium tab driven over the DevTools protocol (what Playwright/Puppeteer speak)."""

    STATE = """(() => ({
      files: [...document.querySelectorAll('.jp-DirListing-itemText')].map(e => e.textContent.trim()),
      tabs: [...document.querySelectorAll('.lm-DockPanel .lm-TabBar-tabLabel')].map(e => e.textContent.trim()),
      kernels: [...document.querySelectorAll('.jp-Toolbar-kernelName')].map(e => e.textContent.trim()),
      toasts: [...document.querySelectorAll('.Toastify__toast')].map(e => e.textContent),
      text: document.body ? document.body.innerText : '',
    }))()"""

    def __init__(self, ws_url: str):
        import websocket  # websocket-client: a jupyter_server dependency, always in the venv

        self.ws = websocket.create_connection(ws_url, timeout=30, suppress_origin=True)
        self.next_id = 0

    def call(self, method: str, **params):
        self.next_id += 1
        self.ws.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self.next_id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg["result"]

    EMPTY = {"files": [], "tabs": [], "kernels": [], "toasts": [], "text": ""}

    def state(self) -> dict:
        try:
            result = self.call("Runtime.evaluate", expression=self.STATE, returnByValue=True)["result"]
        except RuntimeError as exc:
            # a page that is navigating or reloading has no context to evaluate in yet (Chrome says
            # "Inspected target navigated or closed" / "Cannot find context"): nothing shown so far
            if "navigated or closed" in str(exc) or "Cannot find context" in str(exc):
                return dict(self.EMPTY)
            raise
        return result.get("value") or dict(self.EMPTY)

    def wait_for(self, ready, timeout: float) -> tuple[dict, float]:
        """Poll the page until ``ready(state)``; return the state and the seconds it took."""
        t0 = time.monotonic()
        while True:
            state = self.state()
            if ready(state):
                return state, time.monotonic() - t0
            if time.monotonic() - t0 > timeout:
                raise AssertionError(f"page not ready after {timeout} s: { {k: v for k, v in state.items() if k != 'text'} }")
            time.sleep(0.25)


@pytest.fixture
def browser(tmp_path):
    if CHROMIUM is None:
        pytest.skip("Chromium is not installed (apt-get install chromium; .ci/run installs it)")
    profile = tmp_path / "chromium-profile"
    proc = subprocess.Popen([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                             "--disable-component-update", "--disable-sync", "--no-first-run",
                             f"--user-data-dir={profile}", f"--window-size={WIDTH},{HEIGHT}",
                             "--remote-debugging-port=0", "--remote-allow-origins=*", "about:blank"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        # Chromium creates DevToolsActivePort and then writes "<port>\n<path>": wait for the
        # port line, not only the file (reading between the two gave an empty file once)
        port_file, deadline, text = profile / "DevToolsActivePort", time.monotonic() + 60, ""
        while time.monotonic() < deadline and proc.poll() is None:
            text = port_file.read_text() if port_file.exists() else ""
            if "\n" in text:
                break
            time.sleep(0.1)
        assert "\n" in text, f"Chromium wrote no debugging port within 60 s (exit code {proc.poll()})"
        port = int(text.split()[0])
        targets = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10).read())
        page = Page(next(t for t in targets if t["type"] == "page")["webSocketDebuggerUrl"])
        page.call("Emulation.setDeviceMetricsOverride", width=WIDTH, height=HEIGHT, deviceScaleFactor=1, mobile=False)
        yield page
        page.ws.close()
    finally:
        left = _stop(proc, str(profile))
        assert not left, f"Chromium processes outlived the test: {left}"


def _lab_shown(state: dict) -> bool:
    return ({"chapters", "exercises"} <= set(state["files"])
            and state["tabs"][:2] == ["00_setup_check.ipynb", "00_setup_exercises.ipynb"]
            and state["kernels"][:2] == ["Python (robocourse)"] * 2)


def test_chromium_shows_both_folders_and_no_news_prompt(lab, browser, tmp_path):
    settings_url = f"/lab/api/settings/{NOTIFICATION}"
    # control first: a user who answers "ask me" (fetchNews "none") gets the prompt in this same
    # lab; how long it takes after the layout shows (2-6 s on a quiet machine, longer under load)
    # sets how long the real check must watch, so a loaded machine cannot make it pass unseen
    lab.send("PUT", settings_url, {"raw": json.dumps({"fetchNews": "none"})})
    browser.call("Page.navigate", url=lab.url("/lab"))
    browser.wait_for(_lab_shown, timeout=90)
    state, delay = browser.wait_for(lambda s: NEWS_PROMPT in s["text"], timeout=90)
    assert any(NEWS_PROMPT in t for t in state["toasts"])
    assert (lab.user_settings / "@jupyterlab/apputils-extension/notification.jupyterlab-settings").is_file()

    # the course's settings as shipped (the user's choice removed): no prompt, watched for twice
    # as long as the control needed to show it
    lab.send("PUT", settings_url, {"raw": "{}"})
    browser.call("Page.reload", ignoreCache=True)
    state, _ = browser.wait_for(_lab_shown, timeout=90)
    watch = max(10.0, 2 * delay + 2.0)
    deadline = time.monotonic() + watch
    while time.monotonic() < deadline:
        state = browser.state()
        assert state["toasts"] == [] and NEWS_PROMPT not in state["text"], state["toasts"]
        time.sleep(0.5)
    shot = base64.b64decode(browser.call("Page.captureScreenshot", format="png")["data"])
    assert shot[:8] == b"\x89PNG\r\n\x1a\n" and int.from_bytes(shot[16:20], "big") == WIDTH
    (tmp_path / "lab.png").write_bytes(shot)
    if os.environ.get("ROBOCOURSE_LAB_SCREENSHOT"):
        Path(os.environ["ROBOCOURSE_LAB_SCREENSHOT"]).write_bytes(shot)


@pytest.mark.skipif(shutil.which("setsid") is None, reason="setsid (util-linux) is not installed")
def test_stop_reports_and_kills_a_process_that_escaped_the_group(tmp_path):
    marker = str(tmp_path / "escaped-marker")
    code = "import time; time.sleep(60)"
    proc = subprocess.Popen(["sh", "-c", f'setsid {sys.executable} -c "{code}" {marker} & exec sleep 60'],
                            start_new_session=True)
    def escaped():
        # the marker is on setsid's command line before setsid(1) leaves the group: a process found in
        # that moment would still die with the group (1 in 100 polls on a loaded machine)
        out = []
        for p in _processes_using(marker):
            with contextlib.suppress(ProcessLookupError):
                if os.getsid(p.pid) != proc.pid:
                    out.append(p)
        return out

    deadline = time.monotonic() + 30
    while not escaped() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert escaped(), "the setsid child never left the test's session"
    left = _stop(proc, marker, pgid=proc.pid, timeout=2)
    assert len(left) == 1 and marker in " ".join(left[0][1])  # found, named, and killed
    assert not psutil.pid_exists(left[0][0]) or psutil.Process(left[0][0]).status() == psutil.STATUS_ZOMBIE
