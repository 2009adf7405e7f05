"""The Snakemake report of the test study (docs/guide/first_study.md), opened in headless Chromium: the JS app
loads without console errors, shows the study's categories, embeds every figure (overview,
Campbell diagram per family, fidelity ladder) as an image, and renders to a screenshot.

Console errors are captured without DevTools: a copy of the report gets a first <script> that
re-logs console.error, uncaught exceptions, unhandled rejections and failed resource loads with
a marker; Chromium's --enable-logging=stderr prints every console message as a CONSOLE line
(all at level INFO, hence the marker). Needs /usr/bin/chromium; as root the test installs
Debian's package, otherwise it is skipped."""
import base64
import fcntl
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from ced.study.cases import chunks
from tests.conftest import shared

ROOT = Path(__file__).resolve().parents[1]
SNAKEFILE = ROOT / "Snakefile"
PROFILE = ROOT / "workflow" / "profiles" / "default"
TEST_STUDY = ROOT / "config" / "studies" / "test.yaml"
CHROMIUM = Path("/usr/bin/chromium")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-logging=stderr", "--v=0", "--virtual-time-budget=10000"]
MARK = "CED-CONSOLE-ERROR"
HOOK = f"""<script>(function () {{
  var mark = "{MARK}: ", error = console.error.bind(console), log = console.log.bind(console);
  console.error = function () {{
    log(mark + Array.prototype.map.call(arguments, String).join(" ")); error.apply(null, arguments);
  }};
  window.addEventListener("error", function (e) {{
    var t = e.target;
    if (t && t !== window && (t.src || t.href)) log(mark + "failed to load " + (t.src || t.href));
    else log(mark + "uncaught " + e.message + " at " + e.filename + ":" + e.lineno);
  }}, true);
  window.addEventListener("unhandledrejection", function (e) {{
    log(mark + "unhandled rejection " + (e.reason && e.reason.stack || e.reason));
  }});
}})();</script>"""


def chromium() -> Path:
    if CHROMIUM.exists():
        return CHROMIUM
    if os.geteuid() != 0 or not shutil.which("apt-get"):
        pytest.skip("needs /usr/bin/chromium (Debian: apt-get install chromium, as root)")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    install = ["apt-get", "install", "-y", "-q", "chromium"]
    # pytest-xdist workers may get here together: one installs, the others wait for it.
    with open("/tmp/ced-chromium-install.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if CHROMIUM.exists():
            return CHROMIUM
        if subprocess.run(install, capture_output=True, env=env, timeout=900).returncode:
            subprocess.run(["apt-get", "update", "-q"], capture_output=True, env=env, timeout=600)
            result = subprocess.run(install, capture_output=True, text=True, env=env,
                                    timeout=900)
            if result.returncode:
                pytest.skip(f"apt-get install chromium failed:\n{result.stdout[-2000:]}"
                            f"\n{result.stderr[-2000:]}")
    return CHROMIUM


def snakemake(*args, directory: Path) -> None:
    cmd = [sys.executable, "-m", "snakemake", "--snakefile", str(SNAKEFILE), "--directory",
           str(directory), "--profile", str(PROFILE), "--cores", "2", *args,
           "--configfile", str(TEST_STUDY)]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=directory)
    assert result.returncode == 0, f"{' '.join(cmd)}\n{result.stdout}\n{result.stderr}"


def browse(*args: str, user_data: Path, timeout=600) -> subprocess.CompletedProcess:
    cmd = [str(chromium()), *FLAGS, f"--user-data-dir={user_data}", *args]
    result = subprocess.run(cmd, capture_output=True, timeout=timeout)
    assert result.returncode == 0, f"{' '.join(cmd)}\n{result.stderr.decode(errors='replace')}"
    return result


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    """The test study run end to end and its report, in a temporary directory."""
    chromium()  # skip before the run if there is no browser

    def build(directory):
        snakemake(directory=directory)
        snakemake("--report", str(directory / "results/test/report.html"), directory=directory)

    return shared(tmp_path_factory, "ced-report", build) / "results" / "test" / "report.html"


@pytest.fixture(scope="module")
def loaded(report, tmp_path_factory) -> tuple[str, list[str]]:
    """The report's DOM after its scripts ran, and the console lines Chromium printed."""
    work = tmp_path_factory.mktemp("chromium")
    html = report.read_text()
    head = re.search(r"<head[^>]*>", html)
    assert head, "no <head> in the report"
    hooked = work / "report.html"
    hooked.write_text(html[:head.end()] + HOOK + html[head.end():])
    result = browse("--dump-dom", hooked.as_uri(), user_data=work / "profile")
    stderr = result.stderr.decode(errors="replace")
    console = [line for line in stderr.splitlines() if ":CONSOLE" in line]
    return result.stdout.decode(errors="replace"), console


def test_report_loads_without_console_errors(loaded):
    dom, console = loaded
    errors = [line for line in console if MARK in line or '"Uncaught' in line]
    assert not errors, "\n".join(errors)
    assert '<div id="app">' in dom


def test_report_shows_categories(loaded):
    """The JS app rendered its navigation: the categories of the study's figures."""
    dom, _ = loaded
    app = dom.split('<div id="app">', 1)[1]
    text = " ".join(re.sub(r"<[^>]+>", " ", re.sub(r"<script.*?</script>", "", app,
                                                   flags=re.S)).split())
    for category in ("Overview", "Campbell diagrams", "What accuracy costs in time"):
        assert category in text, text[:2000]
    assert "Loading Snakemake Report" not in text  # the loading screen is gone


def figures() -> list[str]:
    families = sorted(chunks(yaml.safe_load(TEST_STUDY.read_text())))
    return ["results/test/figures/overview.png", "results/test/ladder/ladder.png",
            *(f"results/test/figures/{kind}/{f}.png" for kind in
              ("campbell", "resonance", "worst_case") for f in families)]


@pytest.mark.parametrize("figure", figures(), ids=lambda p: p.split("results/test/")[1])
def test_figure_embedded(report, figure):
    """Each figure is in the report's data by name, with its PNG embedded as a data URI."""
    html = report.read_text()
    start = html.find(f'"{figure}": {{')
    assert start >= 0, f"{figure} not in the report"
    uri = html.find('"data_uri"', start)
    entry = html[uri:html.find('",', uri + len('"data_uri": "')) + 1]  # the whole data URI
    match = re.search(r'"data_uri": "data:image/png;[^"]*?base64,([A-Za-z0-9+/=]+)"', entry)
    assert match, f"{figure}: no embedded PNG"
    png = base64.b64decode(match[1])
    assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 1000
    assert png == (report.parents[2] / figure).read_bytes()


def test_report_screenshot(report, tmp_path):
    shot = tmp_path / "report.png"
    browse(f"--screenshot={shot}", "--window-size=1280,900", report.as_uri(),
           user_data=tmp_path / "profile")
    data = shot.read_bytes()
    assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 10000
