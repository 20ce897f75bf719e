"""What `pip install bw4t` gives without the `rl` extra: the client, `bw4t.sim` and the
command work with Gymnasium and PettingZoo absent, and `bw4t.env` says how to get them."""

import os
import re
import subprocess
import sys
import tarfile
import textwrap
from pathlib import Path

import pytest

WITHOUT_RL = textwrap.dedent(
    """
    import sys
    # As if neither were installed: importing either raises ModuleNotFoundError.
    sys.modules["gymnasium"] = None
    sys.modules["pettingzoo"] = None
    import bw4t
    from bw4t import Client, AsyncClient, BeliefBase
    import bw4t.sim
    match = bw4t.sim.Match(map="fixed", players=1, teammates=2, seed=3)
    before = match.digest()
    match.step()
    assert match.digest() != before
    try:
        import bw4t.env
    except ImportError as error:
        print(error)
    else:
        raise SystemExit("bw4t.env imported without Gymnasium")
    assert "gymnasium" not in sys.modules or sys.modules["gymnasium"] is None
    """
)


def test_the_client_and_the_simulation_need_no_learning_packages():
    done = subprocess.run([sys.executable, "-c", WITHOUT_RL], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    said = done.stdout.strip()
    assert "pip install 'bw4t[rl]'" in said and "gymnasium" in said, said


def test_the_base_install_asks_only_for_numpy():
    tomllib = pytest.importorskip("tomllib", reason="tomllib is in Python 3.11 and newer")
    pyproject = Path(__file__).resolve().parents[2] / "pyproject.toml"
    project = tomllib.loads(pyproject.read_text())["project"]
    assert [d.split(">")[0] for d in project["dependencies"]] == ["numpy"]
    rl = project["optional-dependencies"]["rl"]
    assert sorted(d.split(">")[0] for d in rl) == ["gymnasium", "pettingzoo"]
    for extra in ("test", "train"):
        assert "bw4t[rl]" in project["optional-dependencies"][extra], extra


def test_the_wheel_has_a_manylinux_tag_its_symbols_allow():
    wheel = os.environ.get("BW4T_WHEEL")
    if not wheel:
        pytest.skip("BW4T_WHEEL (the wheel ./test.sh builds) is not set")
    pytest.importorskip("auditwheel", reason="auditwheel is not installed")
    shown = subprocess.run(
        [sys.executable, "-m", "auditwheel", "show", wheel], capture_output=True, text=True, timeout=120
    )
    assert shown.returncode == 0, shown.stderr
    said = " ".join(shown.stdout.split())
    tag = Path(wheel).name.rsplit("-", 1)[1].removesuffix(".whl")
    assert tag.startswith("manylinux_"), tag
    assert f'is consistent with the following platform tag: "{tag}"' in said, said


def test_an_sdist_builds_with_the_rust_half_in_it(tmp_path):
    maturin = Path(sys.executable).parent / "maturin"
    if not maturin.exists():
        pytest.skip("maturin is not installed beside this Python")
    root = Path(__file__).resolve().parents[2]
    built = subprocess.run(
        [str(maturin), "sdist", "-o", str(tmp_path)], cwd=root, capture_output=True, text=True, timeout=300
    )
    assert built.returncode == 0, built.stderr
    (sdist,) = tmp_path.glob("bw4t-*.tar.gz")
    with tarfile.open(sdist) as archive:
        names = {name.split("/", 1)[-1] for name in archive.getnames()}
    for needed in ("pyproject.toml", "Cargo.lock", "crates/bw4t-py/Cargo.toml", "python/bw4t/__init__.py"):
        assert needed in names, f"{needed} is not in {sdist.name}"
    # Every file a crate's code reads at compile time, wherever it lies, or the sdist would
    # not build; but the test fixtures (tests/), which only the crates' own tests read.
    compiled_in = set()
    for source in (root / "crates").rglob("*.rs"):
        if "tests" in source.relative_to(root).parts or source.name == "tests.rs":
            continue
        for relative in re.findall(r'include_(?:str|bytes)!\("([^"]+)"\)', source.read_text(encoding="utf-8")):
            path = (source.parent / relative).resolve().relative_to(root).as_posix()
            if not path.startswith("tests/"):
                compiled_in.add(path)
    assert "maps/default.toml" in compiled_in and len(compiled_in) > 20, sorted(compiled_in)
    missing = sorted(compiled_in - names)
    assert not missing, f"{sdist.name} lacks what the crates include: {missing}"
