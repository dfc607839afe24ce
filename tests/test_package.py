"""The package people install: ``python -m build`` makes a wheel and an sdist (offline: the build tools come with
the test extra), the wheel carries the licence, ``py.typed`` and the viewer's page, and installed in a fresh
environment it runs ``manifill demo`` and says what the pictures need when they cannot be drawn."""

import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def dist(tmp_path_factory):
    pytest.importorskip("build")
    out = tmp_path_factory.mktemp("dist")
    done = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "-o", str(out), str(ROOT)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return out


def test_build_makes_a_wheel_and_an_sdist_with_the_licence(dist):
    wheel, = dist.glob("manifill-*.whl")
    sdist, = dist.glob("manifill-*.tar.gz")
    names = zipfile.ZipFile(wheel).namelist()
    assert "manifill/py.typed" in names and "manifill/viz/viewer.html" in names
    assert any(n.endswith("licenses/LICENSE") for n in names)
    meta = zipfile.ZipFile(wheel).read(next(n for n in names if n.endswith("METADATA"))).decode()
    assert "License-Expression: MIT" in meta and "Author: the manifill developers" in meta
    assert sdist.stat().st_size > 0


def test_the_wheel_installed_in_a_fresh_environment_runs_the_demo(dist, tmp_path):
    wheel, = dist.glob("manifill-*.whl")
    env = tmp_path / "env"
    # the dependencies come from this environment (no download: its site-packages on the path, but not its .pth
    # files, so not this checkout's editable manifill); the package itself only from the wheel
    venv.EnvBuilder(with_pip=False).create(env)
    py = env / "bin" / "python"
    own = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                         capture_output=True, text=True, timeout=120).stdout.strip()
    here = {sysconfig.get_paths()[k] for k in ("purelib", "platlib")}
    Path(own, "zz_dependencies.pth").write_text("\n".join(sorted(here)) + "\n")
    done = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "--no-deps", "--no-index",
                           "--force-reinstall", str(wheel)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    where = subprocess.run([str(py), "-c", "import manifill; print(manifill.__file__)"], capture_output=True,
                           text=True, timeout=120)
    assert str(env) in where.stdout, where.stdout + where.stderr  # the wheel's copy, not the checkout's
    demo = subprocess.run([str(env / "bin" / "manifill"), "demo", "-o", str(tmp_path / "d"), "--level", "3",
                           "--no-pictures"], capture_output=True, text=True, timeout=600,
                          env={"PATH": f"{env / 'bin'}", "HOME": str(tmp_path)})
    assert demo.returncode == 0, demo.stderr[-2000:]
    assert "relative RMSE" in demo.stdout and (tmp_path / "d" / "sphere.vtu").is_file()
