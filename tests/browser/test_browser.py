"""The compendium in a real browser (``make test-browser``; not part of ``make test``).

Headless Chromium (Debian's ``chromium``, installed with apt-get when missing) driven by Playwright:

* JupyterLab on a free local port (token auth, ``--allow-root`` as root) with the same save hook as
  ``make lab``: the overview runs and renders the verdict summary and table, and saving it leaves the
  committed notebook byte for byte as it was; chapter 6's notebook (a copy with ``quick = True``)
  runs all cells, its figures render, and dragging its Explore section's ``alpha`` slider changes
  the plotted output (the rendered image before and after differ);
* the built book (``make book``), served locally by ``book/serve.py``: the index and chapter 6's page
  with its figures, equations and the Explore section's static image, loading nothing from the internet.

Screenshots go to ``build/screenshots/``; the servers this test starts are stopped at the end.
Needs ``make figures`` and ``make book`` first (the overview shows the committed results; the book
is built from the executed notebooks).
"""

import contextlib
import json
import os
import re
import secrets
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers.servers import free_port, wait_for_http
from playwright.sync_api import expect

ROOT = Path(__file__).resolve().parents[2]
SHOTS = ROOT / "build" / "screenshots"
WORK = ROOT / "build" / "browser-test"
BOOK = ROOT / "build" / "book"
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync"]
CHAPTER = "05_legibility_lqr.ipynb"        # chapter 6: its Explore view answers in about a second
RUN_TIMEOUT = 900                         # seconds for "run all cells" of one notebook


def fail(step, err=None):
    pytest.fail(f"browser test: {step}{f': {err}' if err else ''}", pytrace=False)


@contextlib.contextmanager
def step(page, name):
    """One named step: on any failure, a screenshot ``failed-<name>.png`` and one clear line."""
    try:
        yield
    except Exception as err:  # noqa: BLE001 (every failure becomes one line naming the step)
        shot = SHOTS / f"failed-{re.sub(r'[^A-Za-z0-9]+', '-', name).strip('-')}.png"
        with contextlib.suppress(Exception):
            page.screenshot(path=str(shot), full_page=False)
        message = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        fail(f"{name} failed ({message}); screenshot {shot.relative_to(ROOT)}")


def stop(process):
    """Stop a server started in its own session: SIGTERM to its group, SIGKILL after 20 s."""
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=10)


def ensure_chromium():
    """Debian's chromium, installed with apt-get when missing (as root; otherwise a clear failure)."""
    if Path(CHROMIUM).is_file():
        return CHROMIUM
    if os.geteuid() != 0:
        fail(f"no {CHROMIUM}: install Debian's chromium (`sudo apt-get install chromium`) and run again")
    print(f"==> installing Debian's chromium (apt-get; {CHROMIUM} is missing)", flush=True)
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for command in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", "chromium"]):
        done = subprocess.run(command, capture_output=True, text=True, env=env)
        if done.returncode != 0:
            fail(f"`{' '.join(command)}` failed: {(done.stderr or done.stdout).strip().splitlines()[-1:]}")
    if not Path(CHROMIUM).is_file():
        fail(f"apt-get installed chromium but there is no {CHROMIUM}")
    return CHROMIUM


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    executable = ensure_chromium()
    SHOTS.mkdir(parents=True, exist_ok=True)
    profile = WORK / "chromium-profile"
    shutil.rmtree(profile, ignore_errors=True)
    with sync_playwright() as pw:
        try:
            context = pw.chromium.launch_persistent_context(
                str(profile), executable_path=executable, headless=True, args=CHROMIUM_FLAGS,
                viewport={"width": 1400, "height": 1000})
        except Exception as err:  # noqa: BLE001
            fail(f"starting {executable} through Playwright", str(err).splitlines()[0])
        yield context
        context.close()


@pytest.fixture(scope="module")
def lab():
    """JupyterLab as `make lab` starts it (root dir = repository, the stripping save hook), on a free
    port with a token; outputs of what runs there go to a scratch folder of this test."""
    shutil.rmtree(WORK / "scratch", ignore_errors=True)
    port, token = free_port(), secrets.token_hex(16)
    jupyter = Path(sys.executable).parent / "jupyter"
    command = [str(jupyter), "lab", "--no-browser", f"--port={port}", "--ServerApp.ip=127.0.0.1",
               f"--IdentityProvider.token={token}", f"--ServerApp.root_dir={ROOT}",
               "--ContentsManager.pre_save_hook=mutual.compendium.hygiene.strip_before_save",
               "--LabApp.news_url=None", "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
               "--LabApp.expose_app_in_browser=True"] + (["--allow-root"] if os.geteuid() == 0 else [])
    # the kernels draw as a reader's do (inline), not with the Agg backend tests/conftest.py sets for pytest
    env = {**{k: v for k, v in os.environ.items() if k != "MPLBACKEND"}, "MUTUAL_OUTPUT_DIR": str(WORK / "scratch"), "JUPYTER_CONFIG_DIR": str(WORK / "jupyter-config"),
           "JUPYTERLAB_SETTINGS_DIR": str(WORK / "lab-settings"), "JUPYTERLAB_WORKSPACES_DIR": str(WORK / "lab-workspaces")}
    WORK.mkdir(parents=True, exist_ok=True)
    # every cell in the page (JupyterLab 4 otherwise renders only the cells in view), and no news toast
    for plugin, settings in (("notebook-extension/tracker", {"windowingMode": "none"}),
                             ("apputils-extension/notification", {"fetchNews": "false"})):
        path = WORK / "lab-settings" / "@jupyterlab" / f"{plugin}.jupyterlab-settings"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(settings))
    log = open(WORK / "lab.log", "w")
    server = subprocess.Popen(command, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        wait_for_http(f"http://127.0.0.1:{port}/api/status?token={token}", server, "JupyterLab")
        yield f"http://127.0.0.1:{port}", token
    finally:
        stop(server)
        log.close()


@pytest.fixture(scope="module")
def book_server():
    if not (BOOK / "index.html").is_file():
        fail("no build/book/index.html: run `make figures` and `make book` first")
    port = free_port()
    server = subprocess.Popen([sys.executable, str(ROOT / "book" / "serve.py"), "--port", str(port), str(BOOK)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
                              env={**os.environ, "BOOK_SERVER_QUIET": "1"})
    try:
        wait_for_http(f"http://127.0.0.1:{port}/", server, "the static server of build/book")
        yield f"http://127.0.0.1:{port}"
    finally:
        stop(server)


def open_notebook(page, base, token, path):
    page.goto(f"{base}/lab/tree/{path}?token={token}&reset", wait_until="domcontentloaded")
    page.wait_for_function("() => window.jupyterapp && window.jupyterapp.shell.currentWidget "
                           "&& window.jupyterapp.shell.currentWidget.sessionContext", timeout=120_000)
    page.wait_for_function("() => { const w = window.jupyterapp.shell.currentWidget;"
                           " const k = w.sessionContext.session && w.sessionContext.session.kernel;"
                           " return k && k.name === 'mutual' && w.sessionContext.kernelDisplayStatus === 'idle'; }",
                           timeout=180_000)


def run_all(page):
    """Run every cell and wait until each code cell has an execution count and the kernel is idle."""
    page.evaluate("() => window.jupyterapp.commands.execute('notebook:run-all-cells')")
    page.wait_for_function(
        "() => { const w = window.jupyterapp.shell.currentWidget; const cells = w.content.widgets;"
        " const code = cells.filter(c => c.model.type === 'code');"
        " return code.every(c => c.model.executionCount !== null && c.model.executionCount !== undefined)"
        " && w.sessionContext.kernelDisplayStatus === 'idle'; }", timeout=RUN_TIMEOUT * 1000, polling=1000)
    errors = page.locator(".jp-OutputArea-output[data-mime-type='application/vnd.jupyter.stderr']")
    tracebacks = page.locator(".jp-RenderedText[data-mime-type='application/vnd.jupyter.error']")
    if tracebacks.count():
        raise AssertionError(f"a cell raised: {tracebacks.first.inner_text()[:300]}")
    return errors.count()


# the src of the last interact view's image, once it differs from `before` and has loaded
EXPLORE_IMAGE_CHANGED = """before => {
    const views = document.querySelectorAll('.widget-interact');
    const img = views.length && views[views.length - 1].querySelector('.jp-OutputArea-output img');
    return img && img.complete && img.naturalWidth > 0 && img.getAttribute('src') !== before;
}"""


def settled_image(page, interact, quiet=3, timeout=180):
    """The interact view's image once the kernel is idle and the image has not changed for ``quiet`` seconds."""
    last, same, deadline = None, 0, time.time() + timeout
    while time.time() < deadline:
        time.sleep(1)
        images = interact.locator(".jp-OutputArea-output img")
        src = images.first.get_attribute("src") if images.count() else None
        idle = page.evaluate("() => window.jupyterapp.shell.currentWidget.sessionContext.kernelDisplayStatus === 'idle'")
        same = same + 1 if (src is not None and src == last and idle) else 0
        if same >= quiet:
            return src
        last = src
    raise AssertionError(f"the Explore view did not settle within {timeout} s")


def rendered_images(page, scope=".jp-Notebook"):
    return page.evaluate(f"() => Array.from(document.querySelectorAll('{scope} .jp-OutputArea-output img'))"
                         ".map(i => [i.naturalWidth, i.naturalHeight])")


def test_overview_runs_and_saves_unchanged(browser, lab):
    base, token = lab
    page = browser.new_page()
    overview = ROOT / "notebooks" / "00_overview.ipynb"
    committed = overview.read_bytes()
    with step(page, "opening 00_overview.ipynb in JupyterLab"):
        open_notebook(page, base, token, "notebooks/00_overview.ipynb")
    with step(page, "running all cells of the overview"):
        run_all(page)
        summary = page.locator(".jp-OutputArea .jp-RenderedMarkdown", has_text="Summary:")
        summary.first.wait_for(timeout=30_000)
        assert "reproduced" in summary.first.inner_text(), "the verdict summary line is not rendered"
        assert page.locator(".jp-OutputArea-output table").count() >= 1, "the chapter x verdict table is not rendered"
    page.screenshot(path=str(SHOTS / "lab-overview.png"))
    with step(page, "saving the overview (the save hook strips its outputs)"):
        page.evaluate("() => window.jupyterapp.commands.execute('docmanager:save')")
        page.wait_for_function("() => !window.jupyterapp.shell.currentWidget.context.model.dirty", timeout=30_000)
        time.sleep(1)
        assert overview.read_bytes() == committed, "saving from the lab changed notebooks/00_overview.ipynb"
    page.close()


def test_chapter_six_figures_and_widget(browser, lab):
    base, token = lab
    copy = WORK / CHAPTER
    nb = json.loads((ROOT / "notebooks" / CHAPTER).read_text())
    tagged = [c for c in nb["cells"] if "parameters" in c["metadata"].get("tags", [])]
    tagged[0]["source"] = "".join(tagged[0]["source"]).replace("quick = False", "quick = True")
    copy.write_text(json.dumps(nb, indent=1))
    page = browser.new_page()
    with step(page, f"opening {CHAPTER} (a copy with quick = True) in JupyterLab"):
        open_notebook(page, base, token, copy.relative_to(ROOT).as_posix())
    with step(page, f"running all cells of {CHAPTER}"):
        run_all(page)
    with step(page, "checking that the figures render"):
        images = rendered_images(page)
        assert len(images) >= 4 and all(w > 100 and h > 100 for w, h in images), f"rendered figures {images}"
    page.locator(".jp-OutputArea-output img").first.scroll_into_view_if_needed()
    page.screenshot(path=str(SHOTS / "lab-chapter6.png"))
    interact = page.locator(".widget-interact").last
    output = interact.locator(".jp-OutputArea-output img").first
    with step(page, "finding the Explore section's alpha slider and its figure"):
        interact.scroll_into_view_if_needed()
        output.wait_for(timeout=60_000)
        slider = interact.locator(".widget-slider", has_text="alpha").first
        readout = slider.locator(".widget-readout")
        before_value, before_image = readout.inner_text(), output.get_attribute("src")
    interact.screenshot(path=str(SHOTS / "lab-chapter6-explore-before.png"))
    with step(page, "dragging the alpha slider"):
        handle = slider.locator(".noUi-handle").first
        box = handle.bounding_box()
        track = slider.locator(".noUi-target, .slider").first.bounding_box()
        page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.mouse.down()
        page.mouse.move(track["x"] + track["width"] * 0.2, box["y"] + box["height"] / 2, steps=12)
        page.mouse.up()
        page.wait_for_function(EXPLORE_IMAGE_CHANGED, arg=before_image, timeout=120_000)
    with step(page, "comparing the plotted output before and after"):
        after_image = settled_image(page, interact)   # the drag queues a view per value it passed
        after_value = readout.inner_text()
        assert after_value != before_value, f"the slider still reads {after_value}"
        assert after_image and after_image != before_image, "the figure did not change"
    interact.screenshot(path=str(SHOTS / "lab-chapter6-explore-after.png"))
    print(f"alpha {before_value} -> {after_value}: the Explore figure changed")
    page.close()


def test_book_index_and_chapter(browser, book_server):
    page = browser.new_page()
    outside = []
    page.on("request", lambda r: None if r.url.startswith((book_server, "data:", "blob:")) else outside.append(r.url))
    with step(page, "opening the book's index"):
        page.goto(f"{book_server}/", wait_until="networkidle")
        page.get_by_role("heading", level=1).first.wait_for(timeout=30_000)
        assert "Mutual understanding in motion" in page.title() + page.inner_text("body")
        toc = page.get_by_role("link", name="Chapter 6")
        assert toc.count() >= 1, "the table of contents does not list chapter 6"
        assert page.get_by_role("link", name="Reproduction report").count() >= 1, "no link to the reproduction report"
    page.screenshot(path=str(SHOTS / "book-index.png"))
    with step(page, "opening chapter 6's page"):
        page.get_by_role("link", name="Chapter 6").first.click()
        page.wait_for_load_state("networkidle")
        page.get_by_role("heading", level=1, name="Chapter 6").first.wait_for(timeout=30_000)
    with step(page, "checking chapter 6's figures, equations and Explore image"):
        images = page.evaluate("() => Array.from(document.images).filter(i => i.src.includes('/build/'))"
                               ".map(i => [i.naturalWidth, i.naturalHeight])")
        assert len(images) >= 5 and all(w > 100 and h > 100 for w, h in images), f"page images {images}"
        assert page.locator(".katex").count() > 10, "the equations are not typeset (no KaTeX output)"
        katex_font = page.evaluate("() => getComputedStyle(document.querySelector('.katex')).fontFamily")
        assert "KaTeX" in katex_font, f"KaTeX's stylesheet did not load (font {katex_font!r})"
        explore = page.get_by_text("Controls (their initial values", exact=False)
        expect(explore.first).to_contain_text("alpha = 1;", timeout=30_000)
        page.get_by_role("heading", name="Explore").first.scroll_into_view_if_needed()
        time.sleep(1)
    page.screenshot(path=str(SHOTS / "book-chapter6-explore.png"))
    page.evaluate("() => window.scrollTo(0, 0)")
    page.screenshot(path=str(SHOTS / "book-chapter6.png"))
    page.screenshot(path=str(SHOTS / "book-chapter6-full.png"), full_page=True)
    assert not outside, f"the book loaded from outside the local server: {sorted(set(outside))[:5]}"
    page.close()
