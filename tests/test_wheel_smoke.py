"""Issue 20's wheel flow, part of the README's test command (so CI runs it): build the wheel,
install it NON-editable into a fresh venv and run ``rvtool`` from a directory outside the
checkout, where no ``cases/`` folder and no source tree can help it.

Offline and short: the wheel is built without build isolation (setuptools and wheel of this
environment, from the ``test`` extra), the venv sees the site-packages of the environment running
the tests (a ``.pth`` file in the venv adds them, :func:`outer_site_dirs`) and the wheel is
installed with ``--no-deps --no-index``, so the heavy dependencies are reused and nothing is
downloaded. Not ``--system-site-packages``: created from inside a virtual environment, that sees
the base interpreter's packages, not the environment's (issue 27: ``ModuleNotFoundError: tomlkit``
where the dependencies live in the virtual environment only). rvtool itself must come from the
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


def outer_site_dirs():
    """The site directories of the interpreter running the tests, in path order: the virtual
    environment's own site-packages (and, where it was made with --system-site-packages, the base
    interpreter's after them), or the system interpreter's. Whatever this interpreter imports from
    an installed distribution comes from one of them."""
    import site
    dirs = [p for p in sys.path if Path(p).name in ("site-packages", "dist-packages") and Path(p).is_dir()]
    user = site.getusersitepackages() if site.ENABLE_USER_SITE else None
    if user and Path(user).is_dir() and user not in dirs:
        dirs.append(user)
    return dirs


def see_outer_site(venv_python, cwd, env):
    """Let the venv of ``venv_python`` import what this interpreter imports: a ``.pth`` file in the
    venv's site-packages runs ``site.addsitedir`` on each of :func:`outer_site_dirs` (their own
    ``.pth`` files included, as --system-site-packages would), after the venv's own directory, so a
    package installed into the venv wins."""
    purelib = _run([str(venv_python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                   cwd, env).strip()
    lines = [f"import site; site.addsitedir({d!r})" for d in outer_site_dirs()]
    (Path(purelib) / "_rvtool_test_outer_site.pth").write_text("\n".join(lines) + "\n")


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
    _run([sys.executable, "-m", "venv", str(venv)], tmp_path, env)
    bin_dir = venv / ("Scripts" if os.name == "nt" else "bin")
    see_outer_site(bin_dir / "python", tmp_path, env)
    # the venv imports the dependencies this interpreter imports (in a virtual environment: from it,
    # not from the base interpreter; --system-site-packages failed there with ModuleNotFoundError)
    probe = "import json, tomlkit, numpy; print(json.dumps([tomlkit.__file__, numpy.__file__]))"
    import numpy
    import tomlkit
    seen = json.loads(_run([str(bin_dir / "python"), "-c", probe], tmp_path, env))
    assert seen == [tomlkit.__file__, numpy.__file__], (seen, sys.prefix)
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
