"""Issue 20's wheel flow, part of the README's test command (so CI runs it): build the wheel,
install it NON-editable into a fresh venv and run ``rvtool`` from a directory outside the
checkout, where no ``cases/`` folder and no source tree can help it.

Offline and short: the wheel is built without build isolation (setuptools and wheel of this
environment, from the ``test`` extra), the venv sees this environment's site-packages
(``--system-site-packages``) and the wheel is installed with ``--no-deps --no-index``, so the
heavy dependencies are reused and nothing is downloaded. rvtool itself must come from the
venv (asserted: the editable install of the checkout must not be what runs). The analyses run
the cheapest protocol that still builds a model from a design and solves it (``stiffness``,
quick): what the flow proves is that the installed package finds its shipped designs,
writes templates and runs an analysis to results.json and report.html, not the figures
(tests/test_analyze.py checks those). ``.ci/wheel_smoke`` is the same flow against a venv
that downloads every dependency (a clean-room check, minutes; run by hand).
"""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NOT_SOURCE = (".git", "results", "build", "dist", "*.egg-info", "__pycache__", ".pytest_cache", ".benchmarks",
              ".device", ".whl", "solution", ".venv", "venv")
"""Paths of a checkout that are not the package's source (outputs, caches, other environments)."""


def _run(cmd, cwd, env, timeout=300):
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{' '.join(map(str, cmd))}: exit {proc.returncode}\n{proc.stdout[-3000:]}\n" \
                                 f"{proc.stderr[-3000:]}"
    return proc.stdout


def test_wheel_installs_and_analyzes_outside_the_checkout(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "RVTOOL_CASES")}
    env["MPLBACKEND"] = "Agg"
    # build from a copy: an in-tree build would leave build/ and *.egg-info in the checkout
    src = tmp_path / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(*NOT_SOURCE))
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index", "-q",
          "-w", str(tmp_path / "dist"), str(src)], tmp_path, env)
    wheels = list((tmp_path / "dist").glob("rvtool-*.whl"))
    assert len(wheels) == 1, wheels
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], tmp_path, env)
    bin_dir = venv / ("Scripts" if os.name == "nt" else "bin")
    _run([str(bin_dir / "python"), "-m", "pip", "install", "--no-deps", "--no-index", "-q", str(wheels[0])],
         tmp_path, env)
    env["PATH"] = os.pathsep.join([str(bin_dir), env.get("PATH", "")])
    work = tmp_path / "work"
    work.mkdir()
    where = _run([str(bin_dir / "python"), "-c", "import rvtool; print(rvtool.__file__)"], work, env).strip()
    assert Path(where).resolve().is_relative_to(venv.resolve()), f"rvtool imported from {where}, not the wheel"

    rvtool = str(bin_dir / "rvtool")
    listing = _run([rvtool, "designs"], work, env)
    assert "rd40" in listing and "does not load" not in listing, listing
    _run([rvtool, "new", "--topology", "cycloid", "--name", "mine"], work, env)
    for design, out in (("rd40", "rd40_quick"), ("mine.toml", "mine_quick")):
        _run([rvtool, "analyze", design, "--quick", "--quiet", "--protocols", "stiffness", "--out", out], work, env)
        data = json.loads((work / out / "results.json").read_text())
        assert data["protocols"] == ["stiffness"] and data["stiffness"]["status"] == "ok", data["stiffness"]
        assert data["stiffness"]["figures"]["Kt_condensed"]["value"] > 0
        assert (work / out / "report.html").stat().st_size > 0
