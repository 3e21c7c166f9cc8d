"""The notebook view in a real browser: JupyterLab serving a notebook that
makes a VolumeView, driven by headless Chromium through selenium. What the
user sees is read from the widget's own <img>: the first picture must be
visible (not the near-black frame that alpha dropped on the way gave), and
a drag must turn the volume.

Needs Debian's chromium and chromium-driver (scripts/setup.sh installs
them) and the test extra's jupyterlab and selenium."""

import json
import os
import shutil
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

pytestmark = pytest.mark.skipif(shutil.which("chromedriver") is None,
                                reason="needs chromium-driver (scripts/setup.sh installs it)")

NOTEBOOK = {
    "cells": [{
        "cell_type": "code", "metadata": {}, "execution_count": None, "outputs": [],
        "source": ["from pyvr import VolumeRenderer\n",
                   "from pyvr.datasets import create_sample_volume\n",
                   "from pyvr.notebook import VolumeView\n",
                   "from pyvr.volume import Volume\n",
                   "renderer = VolumeRenderer(256, 256)\n",
                   "renderer.load_volume(Volume(create_sample_volume(64, 'double_sphere')))\n",
                   "VolumeView(renderer)\n"],
    }],
    "metadata": {"kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"}},
    "nbformat": 4, "nbformat_minor": 5,
}

# The pixels of the widget's <img> as shown: drawn into a canvas, RGB only.
READ_PIXELS = """
const img = document.querySelector('.renderview-wrapper img');
if (!img || !img.complete || img.naturalWidth < 16) { return null; }  // before the first frame: a 1x1 placeholder
const c = document.createElement('canvas');
c.width = img.naturalWidth; c.height = img.naturalHeight;
const g = c.getContext('2d');
g.drawImage(img, 0, 0);
const d = g.getImageData(0, 0, c.width, c.height).data;
const rgb = new Array(c.width * c.height * 3);
for (let i = 0, j = 0; i < d.length; i += 4) { rgb[j++] = d[i]; rgb[j++] = d[i + 1]; rgb[j++] = d[i + 2]; }
return [c.width, c.height, img.src, rgb];
"""


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def lab(tmp_path):
    """A JupyterLab server on a free port, serving tmp_path, whose page
    exposes the application (window.jupyterapp) so the test can run cells."""
    pytest.importorskip("jupyterlab")
    (tmp_path / "view.ipynb").write_text(json.dumps(NOTEBOOK))
    port, token = _free_port(), "pyvr-test"
    env = dict(os.environ, JUPYTER_CONFIG_DIR=str(tmp_path / "config"), JUPYTER_RUNTIME_DIR=str(tmp_path / "runtime"),
               JUPYTERLAB_WORKSPACES_DIR=str(tmp_path / "workspaces"), JUPYTERLAB_SETTINGS_DIR=str(tmp_path / "settings"))
    server = subprocess.Popen(
        [sys.executable, "-m", "jupyterlab", "--no-browser", f"--port={port}", "--ip=127.0.0.1",
         f"--ServerApp.token={token}", f"--ServerApp.root_dir={tmp_path}", "--LabApp.expose_app_in_browser=True",
         "--ServerApp.allow_root=True"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            break
        except OSError:
            time.sleep(0.3)
    try:
        yield f"http://127.0.0.1:{port}/lab/tree/view.ipynb?reset&token={token}"
    finally:
        server.terminate()
        server.wait(timeout=30)


@pytest.fixture
def browser():
    webdriver = pytest.importorskip("selenium.webdriver")
    options = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1200,900"):
        options.add_argument(arg)
    if shutil.which("chromium"):
        options.binary_location = shutil.which("chromium")
    driver = webdriver.Chrome(service=webdriver.ChromeService(executable_path=shutil.which("chromedriver")),
                              options=options)
    try:
        yield driver
    finally:
        driver.quit()


def _wait(what, poll, timeout=90.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = poll()
        if value:
            return value
        time.sleep(0.25)
    raise AssertionError(f"timed out waiting for {what}")


def _shown(driver):
    got = driver.execute_script(READ_PIXELS)
    if got is None:
        return None
    w, h, src, rgb = got
    return src, np.asarray(rgb, np.uint8).reshape(h, w, 3)


def _settled(driver, quiet=1.5):
    """The shown frame once its source has not changed for ``quiet`` seconds."""
    src, _ = _shown(driver)
    time.sleep(quiet)
    again = _shown(driver)
    return again if again[0] == src else None


def test_the_view_shows_a_visible_first_picture_and_a_drag_turns_it(lab, browser):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    from selenium.webdriver.common.by import By

    browser.get(lab)
    _wait("JupyterLab", lambda: browser.execute_script("return !!(window.jupyterapp && window.jupyterapp.shell)"))
    _wait("the notebook's kernel", lambda: browser.execute_script(
        "const w = window.jupyterapp.shell.currentWidget;"
        "return !!(w && w.sessionContext && w.sessionContext.session && w.sessionContext.session.kernel"
        " && w.sessionContext.session.kernel.status === 'idle');"))
    browser.execute_script("window.jupyterapp.commands.execute('notebook:run-all-cells');")
    first_src, first = _wait("the view's first frame", lambda: _shown(browser), timeout=120)
    # The first picture over the page's white: bright on average, and the
    # spheres stand out from it (before, the frame reached the browser
    # without alpha: 4.6 of 255 on average, dark grey on black).
    level = first.mean(axis=-1)
    assert level.mean() > 150, level.mean()
    assert (np.abs(level - 255) > 30).mean() > 0.05

    img = browser.find_element(By.CSS_SELECTOR, ".renderview-wrapper img")
    chain = ActionChains(browser).move_to_element(img).click_and_hold()
    for _ in range(10):
        chain = chain.move_by_offset(-12, 0).pause(0.05)
    chain.release().perform()
    # After the release the full frame of the new view arrives; then nothing changes.
    _wait("a frame of the turned view", lambda: (_shown(browser) or (first_src,))[0] != first_src)
    src, after = _wait("the view to settle", lambda: _settled(browser))
    change = np.abs(after.astype(int) - first.astype(int)).mean(axis=-1)
    assert (change > 30).mean() > 0.01, (change > 30).mean()
    assert after.shape == first.shape

    # The view has the focus (it was dragged): the wheel zooms out, and the
    # spheres cover fewer pixels (one step moves the camera 1.1 times as far:
    # about 1/1.21 of the area).
    ActionChains(browser).scroll_from_origin(ScrollOrigin.from_element(img), 0, 300).perform()
    _wait("a frame of the zoomed view", lambda: (_shown(browser) or (src,))[0] != src)
    _, zoomed = _wait("the view to settle", lambda: _settled(browser))

    def covered(rgb):
        return (np.abs(rgb.mean(axis=-1) - 255) > 30).mean()

    assert covered(zoomed) < 0.9 * covered(after), (covered(zoomed), covered(after))
